//! Pictures a user understands at once: an evacuation's GIF plays in under 30 s whatever
//! `--every` is and shows people in most of its frames; a bottleneck's PNG shows the crowd and
//! the exit; a run whose world empties stops there and says so; the page's heat map runs the
//! way the pictures' does.
#![cfg(feature = "render")]

mod common;
use common::{stderr, stdout, throng, tmp};
use throng::render::Palette;

/// Whether a pixel (a palette index) is an agent's.
fn agent(p: u8) -> bool {
    (Palette::GROUP_START..Palette::GROUP_START + Palette::GROUP_COUNT).contains(&p)
}

/// Each frame's delay (hundredths of a second) and its number of agent pixels.
fn gif_frames(path: &std::path::Path) -> Vec<(u16, usize)> {
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::Indexed);
    let mut decoder = options
        .read_info(std::fs::File::open(path).unwrap())
        .unwrap();
    let mut frames = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        let people = frame.buffer.iter().filter(|&&p| agent(p)).count();
        frames.push((frame.delay, people));
    }
    frames
}

/// The PNG's palette indices.
fn png_pixels(path: &std::path::Path) -> Vec<u8> {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Indexed);
    buf.truncate(info.buffer_size());
    buf
}

#[test]
fn an_evacuation_gif_plays_in_under_30_s_with_people_in_most_frames_whatever_every_is() {
    for every in [None, Some("1"), Some("7"), Some("150"), Some("3000")] {
        let path = tmp(&format!("evacuation-{}.gif", every.unwrap_or("default")));
        let mut args = vec![
            "demo",
            "evacuation",
            "--quiet",
            "--size",
            "200",
            "--render",
            path.to_str().unwrap(),
        ];
        if let Some(k) = every {
            args.extend(["--every", k]);
        }
        let o = throng(&args);
        assert!(o.status.success(), "{every:?}: {}", stderr(&o));
        let frames = gif_frames(&path);
        let play: u32 = frames.iter().map(|&(d, _)| u32::from(d)).sum();
        assert!(
            play < 3_000,
            "--every {every:?}: {} frames play {:.1} s",
            frames.len(),
            f64::from(play) / 100.0
        );
        assert!(
            frames.len() >= 2,
            "--every {every:?}: {} frames",
            frames.len()
        );
        let with_people = frames.iter().filter(|&&(_, n)| n > 0).count();
        if every != Some("3000") {
            // (Every 3000 frames is the first and the last frame only.)
            assert!(
                with_people * 4 >= frames.len() * 3,
                "--every {every:?}: people in {with_people} of {} frames",
                frames.len()
            );
        }
        assert!(
            frames.iter().all(|&(d, _)| d >= 2),
            "--every {every:?}: a delay under 2 cs, which browsers slow down"
        );
    }
}

#[test]
fn a_bottleneck_png_shows_the_crowd_and_the_exit() {
    let path = tmp("bottleneck.png");
    let o = throng(&[
        "demo",
        "bottleneck",
        "--quiet",
        "--size",
        "400",
        "--render",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let pixels = png_pixels(&path);
    let people = pixels.iter().filter(|&&p| agent(p)).count();
    // 200 pedestrians of 0.2 m on a picture about 27 pixels a metre: the frame at which half of
    // them have left shows about 100, over 20 pixels each.
    assert!(
        people > 1_000,
        "{people} agent pixels: the crowd is not in the picture"
    );
    let exit = pixels.iter().filter(|&&p| p == Palette::EXIT).count();
    assert!(exit > 0, "the exit is not marked");
}

#[test]
fn a_run_whose_world_empties_stops_there_and_says_so() {
    let o = throng(&["demo", "evacuation", "--every", "50"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        !out.lines()
            .any(|l| l.starts_with("frame") && l.ends_with("agents 0")),
        "timing lines of an empty world:\n{out}"
    );
    let stop = out
        .lines()
        .find(|l| l.starts_with("stopped at frame"))
        .unwrap_or_else(|| panic!("no word of the stop:\n{out}"));
    assert!(stop.contains("every agent has left the world"), "{stop}");
    let frame: u64 = stop.split_whitespace().nth(3).unwrap().parse().unwrap();
    assert!(frame < 3_000, "{stop}");
    assert!(
        out.contains(&format!("summary: {frame} steps")),
        "the summary counts the steps taken:\n{out}"
    );
}
