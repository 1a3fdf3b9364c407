//! Streaming outputs of a run: trajectories (CSV, PedPy text or JuPedSim SQLite, by the file's
//! extension; the library's writers, [`throng::output::trajectory`]), pictures (animated GIF
//! frames as the run goes, or the last frame as PNG) and the measurements' CSV.
//!
//! Every file is written through an [`AtomicOutput`]: complete (renamed into place by
//! [`Outputs::finish`]) or absent (the previous file untouched) after a failure.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use throng::output::AtomicOutput;
use throng::{Error, Result, World};

pub use throng::output::{Format, Sampling, Trajectories};

/// The files a run writes as it goes.
#[derive(Debug, Default)]
pub struct Outputs {
    trajectories: Option<Trajectories>,
    #[cfg(feature = "render")]
    picture: Option<Picture>,
}

#[cfg(feature = "render")]
#[derive(Debug)]
enum Target {
    Gif(Box<throng::render::GifRecorder>),
    Png,
}

#[cfg(feature = "render")]
#[derive(Debug)]
struct Picture {
    painter: throng::render::WorldPainter,
    target: Target,
    /// Declared after `target` so that an unfinished GIF is closed before its file is removed.
    file: AtomicOutput,
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
    /// Opens the requested files (nothing is written for an option that is `None`); the
    /// trajectory file in the format its extension names ([`Format::of`]).
    ///
    /// # Errors
    /// As [`Format::of`] and [`Trajectories::create`]; for the picture, [`Error::Invalid`] for
    /// a bad size or extension and [`Error::Io`] when it cannot be created.
    pub fn open(
        render: Option<&Path>,
        trajectories: Option<(&Path, &Sampling)>,
        world: &World,
        options: RenderOptions,
    ) -> Result<Self> {
        let mut out = Outputs::default();
        if let Some(p) = render {
            out.open_picture(p, world, options)?;
        }
        if let Some((p, sampling)) = trajectories {
            out.trajectories = Some(Trajectories::create(p, Format::of(p)?, sampling, world)?);
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
        if !matches!(ext.as_deref(), Some("gif" | "png")) {
            return Err(Error::Invalid {
                name: "render".into(),
                reason: format!(
                    "{}: the file must end in .gif (animation) or .png (last frame)",
                    path.display()
                ),
            });
        }
        let (file, _) = AtomicOutput::create(path)?;
        let target = match ext.as_deref() {
            Some("gif") => {
                let delay = (options.frame_seconds * 100.0).round().clamp(2.0, 65_535.0) as u16;
                let gif = GifRecorder::create(file.write_path(), w, h, delay)
                    .map_err(|e| file.named(e))?;
                Target::Gif(Box::new(gif))
            }
            Some("png") => Target::Png,
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
        self.picture = Some(Picture {
            painter,
            target,
            file,
        });
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
        if let Some(t) = &mut self.trajectories {
            t.frame(world)?;
        }
        #[cfg(feature = "render")]
        if let Some(p) = &mut self.picture
            && let Target::Gif(gif) = &mut p.target
        {
            let canvas = p.painter.draw(world)?;
            gif.push(canvas).map_err(|e| p.file.named(e))?;
        }
        Ok(())
    }

    /// Flushes and closes everything and moves each complete file into place; a PNG gets the
    /// last frame.
    pub fn finish(mut self, world: &World) -> Result<()> {
        if let Some(t) = self.trajectories.take() {
            t.finish()?;
        }
        #[cfg(feature = "render")]
        if let Some(mut p) = self.picture.take() {
            match p.target {
                Target::Gif(gif) => gif.finish().map_err(|e| p.file.named(e))?,
                Target::Png => {
                    let canvas = p.painter.draw(world)?;
                    throng::render::write_png(canvas, p.file.write_path())
                        .map_err(|e| p.file.named(e))?;
                }
            }
            p.file.commit()?;
        }
        #[cfg(not(feature = "render"))]
        let _ = world;
        Ok(())
    }
}

/// A run's measurements (`[measurements]`, exits) and, with `--measurements FILE`, their
/// per-frame CSV: `frame,t,agents,left`, then per line `<name>_positive,<name>_negative`
/// (cumulative crossings), then per area `<name>_count,<name>_density,<name>_speed` (the
/// speed is empty when nobody is inside).
#[derive(Debug)]
pub struct MeasureOutput {
    recorder: throng::measure::Measurements,
    csv: Option<(BufWriter<File>, AtomicOutput)>,
}

impl MeasureOutput {
    /// A recorder for `spec`, writing its CSV to `path` when given.
    pub fn open(spec: &throng::measure::MeasurementSpec, path: Option<&Path>) -> Result<Self> {
        let recorder = throng::measure::Measurements::new(spec)?;
        let csv = match path {
            Some(p) => {
                let (file, f) = AtomicOutput::create(p)?;
                let mut w = BufWriter::new(f);
                let mut header = String::from("frame,t,agents,left");
                for l in &spec.lines {
                    header += &format!(",{0}_positive,{0}_negative", l.name);
                }
                for a in &spec.areas {
                    header += &format!(",{0}_count,{0}_density,{0}_speed", a.name);
                    if spec.voronoi {
                        header += &format!(",{0}_voronoi_density,{0}_voronoi_speed", a.name);
                    }
                }
                writeln!(w, "{header}").map_err(|e| file.io(e))?;
                Some((w, file))
            }
            None => None,
        };
        Ok(MeasureOutput { recorder, csv })
    }

    /// Observes the world's current frame and writes its row.
    pub fn frame(&mut self, world: &World) -> Result<()> {
        self.recorder.observe(world);
        let Some((w, file)) = &mut self.csv else {
            return Ok(());
        };
        let r = &self.recorder;
        let mut row = format!(
            "{},{:.6},{},{}",
            world.frame(),
            world.time(),
            world.len(),
            r.left()
        );
        for (pos, neg) in r.line_counts() {
            row += &format!(",{pos},{neg}");
        }
        for a in r.area_frames() {
            let speed = a.mean_speed.map(|v| format!("{v:.6}")).unwrap_or_default();
            row += &format!(",{},{:.6},{speed}", a.count, a.density);
            if r.spec().voronoi {
                match a.voronoi {
                    Some(v) => row += &format!(",{:.6},{:.6}", v.density, v.speed),
                    None => row += ",,",
                }
            }
        }
        writeln!(w, "{row}").map_err(|e| file.io(e))
    }

    /// The recorder.
    pub fn recorder(&self) -> &throng::measure::Measurements {
        &self.recorder
    }

    /// Flushes the CSV and moves it into place.
    pub fn finish(&mut self) -> Result<()> {
        if let Some((w, file)) = self.csv.take() {
            w.into_inner().map_err(|e| file.io(e.into_error()))?;
            file.commit()?;
        }
        Ok(())
    }
}
