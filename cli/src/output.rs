//! Streaming outputs of a run: trajectory CSV rows and pictures (animated GIF frames as the run
//! goes, or the last frame as PNG).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use throng::{Error, Result, World};

/// The files a run writes as it goes.
#[derive(Debug, Default)]
pub struct Outputs {
    csv: Option<(BufWriter<File>, String)>,
    #[cfg(feature = "render")]
    picture: Option<Picture>,
}

#[cfg(feature = "render")]
#[derive(Debug)]
enum Target {
    Gif(Box<throng::render::GifRecorder>),
    Png(std::path::PathBuf),
}

#[cfg(feature = "render")]
#[derive(Debug)]
struct Picture {
    painter: throng::render::WorldPainter,
    target: Target,
}

fn io_err(path: &str) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_string(),
        source,
    }
}

/// What to draw and how.
#[derive(Clone, Copy, Debug)]
pub struct RenderOptions {
    /// Longest side of the picture in pixels.
    pub size: u32,
    /// Seconds between written frames (for the GIF's frame delay).
    pub frame_seconds: f32,
}

impl Outputs {
    /// Opens the requested files (nothing is written for an option that is `None`).
    pub fn open(
        render: Option<&Path>,
        trajectories: Option<&Path>,
        world: &World,
        options: RenderOptions,
    ) -> Result<Self> {
        let mut out = Outputs::default();
        if let Some(p) = render {
            out.open_picture(p, world, options)?;
        }
        if let Some(p) = trajectories {
            let name = p.display().to_string();
            let f = File::create(p).map_err(io_err(&name))?;
            let mut w = BufWriter::new(f);
            writeln!(w, "frame,t,id,x,y,vx,vy,heading").map_err(io_err(&name))?;
            out.csv = Some((w, name));
        }
        Ok(out)
    }

    #[cfg(feature = "render")]
    fn open_picture(&mut self, path: &Path, world: &World, options: RenderOptions) -> Result<()> {
        use throng::render::{GifRecorder, WorldPainter, world_extent};
        let (min, max) = world_extent(world);
        let extent = max - min;
        if options.size == 0 {
            return Err(Error::NotPositive {
                name: "size",
                value: 0.0,
            });
        }
        let long = options.size as f32;
        let (w, h) = if extent.x >= extent.y {
            (long, (long * extent.y / extent.x).round().max(1.0))
        } else {
            ((long * extent.x / extent.y).round().max(1.0), long)
        };
        let (w, h) = (w as u32, h as u32);
        let painter = WorldPainter::new(world, w, h)?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let target = match ext.as_deref() {
            Some("gif") => {
                let delay = (options.frame_seconds * 100.0).round().clamp(2.0, 65_535.0) as u16;
                Target::Gif(Box::new(GifRecorder::create(path, w, h, delay)?))
            }
            Some("png") => Target::Png(path.to_path_buf()),
            _ => {
                return Err(Error::Invalid {
                    name: "render".into(),
                    reason: format!(
                        "{}: the file must end in .gif (animation) or .png (last frame)",
                        path.display()
                    ),
                });
            }
        };
        self.picture = Some(Picture { painter, target });
        Ok(())
    }

    #[cfg(not(feature = "render"))]
    fn open_picture(&mut self, path: &Path, _world: &World, _options: RenderOptions) -> Result<()> {
        Err(Error::Invalid {
            name: "render".into(),
            reason: format!("{}: this build has no `render` feature", path.display()),
        })
    }

    /// Writes the world's current frame to every open output.
    pub fn frame(&mut self, world: &World) -> Result<()> {
        if let Some((w, name)) = &mut self.csv {
            let a = world.agents();
            let (frame, t) = (world.frame(), world.time());
            for i in 0..a.len() {
                writeln!(
                    w,
                    "{frame},{t:.6},{},{},{},{},{},{}",
                    a.id(i).0,
                    a.pos_x()[i],
                    a.pos_y()[i],
                    a.vel_x()[i],
                    a.vel_y()[i],
                    a.orientations()[i]
                )
                .map_err(io_err(name))?;
            }
        }
        #[cfg(feature = "render")]
        if let Some(p) = &mut self.picture
            && let Target::Gif(gif) = &mut p.target
        {
            let canvas = p.painter.draw(world)?;
            gif.push(canvas)?;
        }
        Ok(())
    }

    /// Flushes and closes everything; a PNG gets the last frame.
    pub fn finish(mut self, world: &World) -> Result<()> {
        if let Some((mut w, name)) = self.csv.take() {
            w.flush().map_err(io_err(&name))?;
        }
        #[cfg(feature = "render")]
        if let Some(mut p) = self.picture.take() {
            match p.target {
                Target::Gif(gif) => gif.finish()?,
                Target::Png(path) => {
                    let canvas = p.painter.draw(world)?;
                    throng::render::write_png(canvas, &path)?;
                }
            }
        }
        #[cfg(not(feature = "render"))]
        let _ = world;
        Ok(())
    }
}
