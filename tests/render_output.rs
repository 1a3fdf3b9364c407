//! Rendered frames land where the viewport says, point where the agents head, and decode from the
//! files written as GIF and PNG with the stated size and frame count.
#![cfg(feature = "render")]

use std::f32::consts::FRAC_PI_2;
use std::fs::File;

use glam::Vec2;
use proptest::prelude::*;
use throng::Error;
use throng::render::{
    Canvas, GifRecorder, HeatMap, MAX_SIDE, Palette, Scene, Viewport, draw_scene, write_png,
};

fn temp_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("throng-render-{}-{name}", std::process::id()))
}

/// A 100 x 100 canvas showing the world square [0, 100]^2 (one world unit per pixel).
fn unit_canvas() -> (Canvas, Viewport) {
    let canvas = Canvas::new(100, 100).unwrap();
    let vp = Viewport::fit(Vec2::ZERO, Vec2::splat(100.0), &canvas).unwrap();
    (canvas, vp)
}

/// Pixel coordinates of every pixel with colour `colour`.
fn pixels_of(canvas: &Canvas, colour: u8) -> Vec<(i32, i32)> {
    let w = canvas.width() as usize;
    canvas
        .pixels()
        .iter()
        .enumerate()
        .filter(|&(_, &p)| p == colour)
        .map(|(k, _)| ((k % w) as i32, (k / w) as i32))
        .collect()
}

fn one_agent(canvas: &mut Canvas, vp: &Viewport, at: Vec2, heading: f32, radius: f32) {
    let scene = Scene {
        xs: &[at.x],
        ys: &[at.y],
        orientations: &[heading],
        groups: &[2],
        radii: &[radius],
        ..Scene::default()
    };
    draw_scene(canvas, vp, &scene).unwrap();
}

#[test]
fn gif_of_k_frames_decodes_with_its_size_and_frame_count() {
    let path = temp_path("frames.gif");
    let (w, h, k) = (120_u32, 80_u32, 7_usize);
    let mut canvas = Canvas::new(w, h).unwrap();
    let vp = Viewport::fit(Vec2::ZERO, Vec2::new(30.0, 20.0), &canvas).unwrap();
    let mut gif = GifRecorder::create(&path, w, h, 5).unwrap();
    for f in 0..k {
        let x = 2.0 + 3.0 * f as f32;
        draw_scene(
            &mut canvas,
            &vp,
            &Scene {
                xs: &[x],
                ys: &[10.0],
                orientations: &[0.0],
                ..Scene::default()
            },
        )
        .unwrap();
        gif.push(&canvas).unwrap();
    }
    assert_eq!(gif.frames(), k);
    gif.finish().unwrap();

    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::Indexed);
    let mut decoder = options.read_info(File::open(&path).unwrap()).unwrap();
    assert_eq!(
        (u32::from(decoder.width()), u32::from(decoder.height())),
        (w, h)
    );
    assert_eq!(decoder.repeat(), gif::Repeat::Infinite);
    assert_eq!(
        decoder.global_palette().unwrap(),
        &Palette::standard().to_bytes()[..]
    );
    let mut frames = 0;
    let mut last = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        assert_eq!((u32::from(frame.width), u32::from(frame.height)), (w, h));
        assert_eq!(frame.delay, 5);
        last = frame.buffer.to_vec();
        frames += 1;
    }
    assert_eq!(frames, k);
    // The indices come back unchanged: no quantisation.
    assert_eq!(last, canvas.pixels());
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn png_decodes_with_its_size_and_palette() {
    let path = temp_path("last.png");
    let mut canvas = Canvas::new(64, 40).unwrap();
    let vp = Viewport::fit(Vec2::ZERO, Vec2::new(64.0, 40.0), &canvas).unwrap();
    let scene = Scene {
        xs: &[20.0, 40.0],
        ys: &[20.0, 20.0],
        groups: &[0, 1],
        radii: &[4.0, 4.0],
        ..Scene::default()
    };
    draw_scene(&mut canvas, &vp, &scene).unwrap();
    write_png(&canvas, &path).unwrap();

    let decoder = png::Decoder::new(std::io::BufReader::new(File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let info = reader.info();
    assert_eq!((info.width, info.height), (64, 40));
    assert_eq!(info.color_type, png::ColorType::Indexed);
    assert_eq!(
        info.palette.as_deref(),
        Some(&Palette::standard().to_bytes()[..])
    );
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let out = reader.next_frame(&mut buf).unwrap();
    assert_eq!(&buf[..out.buffer_size()], canvas.pixels());
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn io_failures_name_the_file() {
    let (canvas, _) = unit_canvas();
    let bad = std::env::temp_dir()
        .join("throng-no-such-dir")
        .join("x")
        .join("out.png");
    match write_png(&canvas, &bad) {
        Err(Error::Io { path, .. }) => assert!(path.ends_with("out.png")),
        other => panic!("expected Error::Io, got {other:?}"),
    }
    assert!(matches!(
        GifRecorder::create(bad.with_extension("gif"), 10, 10, 1),
        Err(Error::Io { .. })
    ));
}

#[test]
fn bad_sizes_are_rejected() {
    let path = temp_path("never.gif");
    assert!(matches!(
        GifRecorder::create(&path, 0, 10, 1),
        Err(Error::NotPositive { .. })
    ));
    assert!(matches!(
        GifRecorder::create(&path, 10, MAX_SIDE + 1, 1),
        Err(Error::OutOfRange { .. })
    ));
    assert!(!path.exists(), "a rejected size must not create the file");
    assert!(matches!(
        Canvas::new(9000, 9000),
        Err(Error::OutOfRange { .. })
    ));
    let path = temp_path("mismatch.gif");
    let mut gif = GifRecorder::create(&path, 10, 10, 1).unwrap();
    assert!(matches!(
        gif.push(&Canvas::new(11, 10).unwrap()),
        Err(Error::Invalid { .. })
    ));
    drop(gif);
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn triangle_lands_at_its_world_point() {
    let (mut canvas, vp) = unit_canvas();
    // World (30, 70): 30 px from the left, 30 px from the top (y up in the world).
    one_agent(&mut canvas, &vp, Vec2::new(30.0, 70.0), 0.0, 5.0);
    let px = pixels_of(&canvas, Palette::group(2));
    assert!(px.len() > 30, "{} pixels", px.len());
    let (sx, sy) = px.iter().fold((0, 0), |(sx, sy), &(x, y)| (sx + x, sy + y));
    let centre = Vec2::new(sx as f32, sy as f32) / px.len() as f32 + 0.5;
    assert!(
        (centre - Vec2::new(30.0, 30.0)).length() < 3.0,
        "centroid {centre}"
    );
    assert!(
        px.iter()
            .all(|&(x, y)| (x - 30).abs() <= 7 && (y - 30).abs() <= 7)
    );
}

/// Extents of the drawn agent from its centre pixel (50, 50) (world (50.5, 49.5)): (left, right,
/// up, down).
fn extents(heading: f32) -> (i32, i32, i32, i32) {
    let (mut canvas, vp) = unit_canvas();
    one_agent(&mut canvas, &vp, Vec2::new(50.5, 49.5), heading, 15.0);
    let px = pixels_of(&canvas, Palette::group(2));
    let left = px.iter().map(|p| 50 - p.0).max().unwrap();
    let right = px.iter().map(|p| p.0 - 50).max().unwrap();
    let up = px.iter().map(|p| 50 - p.1).max().unwrap();
    let down = px.iter().map(|p| p.1 - 50).max().unwrap();
    (left, right, up, down)
}

#[test]
fn triangles_point_where_agents_head() {
    // Heading east: the nose reaches further right than the tail reaches left; symmetric vertically.
    let (l, r, u, d) = extents(0.0);
    assert!(r > l + 3, "east: left {l}, right {r}");
    assert!((u - d).abs() <= 1, "east: up {u}, down {d}");
    // Heading north (pi/2, counter-clockwise from +x): the nose is up in the picture.
    let (l, r, u, d) = extents(FRAC_PI_2);
    assert!(u > d + 3, "north: up {u}, down {d}");
    assert!((l - r).abs() <= 1, "north: left {l}, right {r}");
    // West and south mirror them.
    let (l, r, ..) = extents(std::f32::consts::PI);
    assert!(l > r + 3, "west: left {l}, right {r}");
    let (_, _, u, d) = extents(-FRAC_PI_2);
    assert!(d > u + 3, "south: up {u}, down {d}");
}

#[test]
fn triangle_mass_sits_behind_the_centre() {
    // The triangle's wide base trails the agent: heading east puts more pixels left of the centre,
    // heading north puts them below; sideways the mass is balanced.
    let mass = |heading: f32| {
        let (mut canvas, vp) = unit_canvas();
        one_agent(&mut canvas, &vp, Vec2::new(50.5, 49.5), heading, 10.0);
        let px = pixels_of(&canvas, Palette::group(2));
        let left = px.iter().filter(|p| p.0 < 50).count() as i32;
        let right = px.iter().filter(|p| p.0 > 50).count() as i32;
        let above = px.iter().filter(|p| p.1 < 50).count() as i32;
        let below = px.iter().filter(|p| p.1 > 50).count() as i32;
        (left, right, above, below)
    };
    let (l, r, a, b) = mass(0.0);
    assert!(l > r, "east: {l} left vs {r} right");
    assert!((a - b).abs() <= 2, "east: {a} above vs {b} below");
    let (l, r, a, b) = mass(FRAC_PI_2);
    assert!(b > a, "north: {a} above vs {b} below");
    assert!((l - r).abs() <= 2, "north: {l} left vs {r} right");
}

#[test]
fn groups_get_different_colours() {
    let (mut canvas, vp) = unit_canvas();
    let scene = Scene {
        xs: &[20.0, 50.0, 80.0],
        ys: &[50.0; 3],
        orientations: &[0.0; 3],
        groups: &[0, 1, 2],
        radii: &[5.0; 3],
        ..Scene::default()
    };
    draw_scene(&mut canvas, &vp, &scene).unwrap();
    let at = |x: u32| canvas.pixel(x, 50).unwrap();
    assert_eq!(
        [at(20), at(50), at(80)],
        [Palette::group(0), Palette::group(1), Palette::group(2)]
    );
    let p = canvas.palette();
    assert!(
        p.rgb(at(20)) != p.rgb(at(50))
            && p.rgb(at(50)) != p.rgb(at(80))
            && p.rgb(at(20)) != p.rgb(at(80))
    );
}

#[test]
fn letterboxed_world_keeps_aspect_and_orientation() {
    // A wide world on a square canvas: bars above and below, x fills the width.
    let mut canvas = Canvas::new(100, 100).unwrap();
    let vp = Viewport::fit(Vec2::ZERO, Vec2::new(200.0, 100.0), &canvas).unwrap();
    // One column of two 50-unit cells, row 0 at the bottom: the lower cell is 0.2, the upper 0.9.
    let heat = HeatMap {
        values: &[0.2, 0.9],
        width: 1,
        height: 2,
        origin: Vec2::ZERO,
        cell_size: 50.0,
        blocked: &[],
    };
    draw_scene(
        &mut canvas,
        &vp,
        &Scene {
            heat: Some(heat),
            ..Scene::default()
        },
    )
    .unwrap();
    assert_eq!(canvas.pixel(10, 10), Some(Palette::BACKGROUND), "top bar");
    assert_eq!(
        canvas.pixel(10, 90),
        Some(Palette::BACKGROUND),
        "bottom bar"
    );
    assert_eq!(canvas.pixel(10, 30), Some(Palette::heat(0.9)), "upper cell");
    assert_eq!(canvas.pixel(10, 70), Some(Palette::heat(0.2)), "lower cell");
    assert_eq!(
        canvas.pixel(60, 50),
        Some(Palette::BACKGROUND),
        "right of the grid"
    );
}

#[test]
fn agents_outside_the_viewport_draw_nothing() {
    let (mut canvas, vp) = unit_canvas();
    let xs = [-50.0, 150.0, 50.0, 50.0, -1e30, 1e30, f32::MAX, -f32::MAX];
    let ys = [50.0, 50.0, -50.0, 150.0, 1e30, -1e30, f32::MAX, 0.0];
    let n = xs.len();
    let scene = Scene {
        xs: &xs,
        ys: &ys,
        orientations: &vec![0.7; n],
        groups: &vec![1; n],
        radii: &vec![5.0; n],
        ..Scene::default()
    };
    draw_scene(&mut canvas, &vp, &scene).unwrap();
    assert!(canvas.pixels().iter().all(|&p| p == Palette::BACKGROUND));
    // Huge agents centred outside still clip cleanly.
    let scene = Scene {
        radii: &vec![1e20; n],
        ..scene
    };
    draw_scene(&mut canvas, &vp, &scene).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// Any finite scene draws without panicking, and agents strictly outside the viewport (by more
    /// than their drawn size) leave the canvas untouched.
    #[test]
    fn drawing_anything_finite_never_panics(
        agents in prop::collection::vec((-1e6_f32..1e6, -1e6_f32..1e6, -10.0_f32..10.0, 0.0_f32..1e4), 0..40),
        circle in (-1e6_f32..1e6, -1e6_f32..1e6, 0.0_f32..1e6),
    ) {
        let (mut canvas, vp) = unit_canvas();
        let xs: Vec<f32> = agents.iter().map(|a| a.0).collect();
        let ys: Vec<f32> = agents.iter().map(|a| a.1).collect();
        let or: Vec<f32> = agents.iter().map(|a| a.2).collect();
        let radii: Vec<f32> = agents.iter().map(|a| a.3).collect();
        let c = Vec2::new(circle.0, circle.1);
        let scene = Scene {
            xs: &xs, ys: &ys, orientations: &or, radii: &radii,
            circles: &[(c, circle.2)],
            segments: &[(c, Vec2::new(circle.1, circle.0))],
            points: &[(c, circle.2)],
            paths: &[vec![c, Vec2::ZERO, Vec2::new(circle.2, -circle.2)]],
            ..Scene::default()
        };
        draw_scene(&mut canvas, &vp, &scene).unwrap();

        let far: Vec<usize> = (0..xs.len())
            .filter(|&i| {
                let reach = 2.0 * radii[i] + 4.0;
                xs[i] < -reach || xs[i] > 100.0 + reach || ys[i] < -reach || ys[i] > 100.0 + reach
            })
            .collect();
        let fx: Vec<f32> = far.iter().map(|&i| xs[i]).collect();
        let fy: Vec<f32> = far.iter().map(|&i| ys[i]).collect();
        let fo: Vec<f32> = far.iter().map(|&i| or[i]).collect();
        let fr: Vec<f32> = far.iter().map(|&i| radii[i]).collect();
        draw_scene(&mut canvas, &vp, &Scene { xs: &fx, ys: &fy, orientations: &fo, radii: &fr, ..Scene::default() }).unwrap();
        prop_assert!(canvas.pixels().iter().all(|&p| p == Palette::BACKGROUND));
    }
}

#[test]
fn pictures_of_several_groups_carry_a_legend() {
    use throng::prelude::*;
    use throng::render::WorldPainter;
    let world = |groups: usize| {
        let mut b = World::builder().bounds(Bounds::bounded(100.0, 100.0).unwrap());
        for g in 0..groups {
            b = b
                .group(Profile::kinematic(SteeringProfile::default()))
                .agent(AgentInit::at(Vec2::new(80.0, 20.0 + 10.0 * g as f32), g));
        }
        b.build().unwrap()
    };
    let two = world(2);
    let mut painter = WorldPainter::new(&two, 200, 200).unwrap();
    let canvas = painter.draw(&two).unwrap();
    assert_eq!(canvas.pixel(7, 7), Some(Palette::group(0)));
    assert_eq!(canvas.pixel(7, 17), Some(Palette::group(1)));
    // The index "1" beside the second swatch: its stem is the middle column of the glyph.
    assert_eq!(canvas.pixel(15, 17), Some(Palette::WHITE));
    let one = world(1);
    let mut painter = WorldPainter::new(&one, 200, 200).unwrap();
    let canvas = painter.draw(&one).unwrap();
    assert_eq!(
        canvas.pixel(7, 7),
        Some(Palette::BACKGROUND),
        "one group, no legend"
    );
}
