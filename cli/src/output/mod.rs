//! Streaming outputs of a run: trajectories (CSV, PedPy text or JuPedSim SQLite, by the file's
//! extension; the library's writers, [`throng::output::trajectory`]), pictures (animated GIF
//! frames as the run goes, timed to play in under 30 s; or one frame as PNG: the last, or the
//! one at which half of the agents had left) and the measurements' CSV.
//!
//! Every file is written through an [`AtomicOutput`]: complete (renamed into place by
//! [`Outputs::finish`]) or absent (the previous file untouched) after a failure.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use throng::output::AtomicOutput;
use throng::{Error, Result, StepStats, World};

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
    /// An animation: a frame every `period` frames of the run (and the last), the frame last
    /// pushed.
    Gif {
        gif: Box<throng::render::GifRecorder>,
        period: u64,
        pushed: Option<u64>,
    },
    /// One picture: the last frame, or, once half of the agents the run started with have
    /// left, the frame at which they had (`frozen` then holds it).
    Png { start: usize, frozen: bool },
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
    /// How an animation samples the run.
    pub gif: GifTiming,
}

/// Longest an animation plays, hundredths of a second (under 30 s).
pub const GIF_PLAY_CS: u64 = 2_900;
/// Most frames an animation holds (frame 0 and the last included), whatever `--every` is.
pub const GIF_MAX_FRAMES: u64 = 300;
/// Longest a frame of an animation is shown, hundredths of a second.
pub const GIF_MAX_DELAY_CS: u64 = 50;
/// Shortest frame delay that browsers honour, hundredths of a second.
pub const GIF_MIN_DELAY_CS: u64 = 2;

/// How an animated GIF samples a run: a frame every `period` frames of the run (and the last),
/// each shown `delay_cs` hundredths of a second.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GifTiming {
    /// Frames of the run between two frames of the animation.
    pub period: u64,
    /// How long each frame is shown, hundredths of a second.
    pub delay_cs: u16,
}

impl GifTiming {
    /// The timing of an animation of a run of `steps` steps of `dt` seconds, with frames every
    /// `every` frames when given (else about 200 frames over the run).
    ///
    /// The period is `every` (or `steps / 200`) times the smallest whole factor that keeps the
    /// animation within [`GIF_MAX_FRAMES`]; a frame is shown for the simulated time it covers,
    /// held within [`GIF_MIN_DELAY_CS`] and [`GIF_MAX_DELAY_CS`] and short enough that the whole
    /// animation plays within [`GIF_PLAY_CS`]. A run that stops early (its world emptied, or
    /// `--until-arrived`) only plays shorter.
    #[must_use]
    pub fn plan(dt: f32, steps: u64, every: Option<u64>) -> Self {
        let base = every.unwrap_or(steps / 200).max(1);
        // Frame 0, a frame every `base` frames, and the last.
        let pictures = steps / base + 2;
        let thin = pictures.div_ceil(GIF_MAX_FRAMES);
        let period = base.saturating_mul(thin);
        let frames = steps / period + 2;
        let longest = (GIF_PLAY_CS / frames).clamp(GIF_MIN_DELAY_CS, GIF_MAX_DELAY_CS);
        let real = f64::from(dt) * period as f64 * 100.0;
        let delay = if real.is_finite() {
            (real.round() as u64).clamp(GIF_MIN_DELAY_CS, longest)
        } else {
            longest
        };
        GifTiming {
            period,
            delay_cs: delay as u16,
        }
    }
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
        let wrong = || Error::Invalid {
            name: "render".into(),
            reason: format!(
                "{}: the file must end in .gif (animation) or .png (one frame)",
                path.display()
            ),
        };
        if !matches!(ext.as_deref(), Some("gif" | "png")) {
            return Err(wrong());
        }
        let (file, _) = AtomicOutput::create(path)?;
        let target = match ext.as_deref() {
            Some("gif") => {
                let gif = GifRecorder::create(file.write_path(), w, h, options.gif.delay_cs)
                    .map_err(|e| file.named(e))?;
                Target::Gif {
                    gif: Box::new(gif),
                    period: options.gif.period,
                    pushed: None,
                }
            }
            Some("png") => Target::Png {
                start: world.len(),
                frozen: false,
            },
            _ => return Err(wrong()),
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

    /// Writes the world's current frame to the trajectory file.
    pub fn frame(&mut self, world: &World) -> Result<()> {
        if let Some(t) = &mut self.trajectories {
            t.frame(world)?;
        }
        Ok(())
    }

    /// Shows the world's current frame to the picture: called at the start and after every
    /// step, it pushes an animation's frame when the frame number is a multiple of its period
    /// (and at the start), and holds a PNG's frame once half of the agents have left.
    pub fn picture(&mut self, world: &World) -> Result<()> {
        #[cfg(feature = "render")]
        if let Some(p) = &mut self.picture {
            match &mut p.target {
                Target::Gif {
                    gif,
                    period,
                    pushed,
                } => {
                    if pushed.is_none() || world.frame().is_multiple_of(*period) {
                        let canvas = p.painter.draw(world)?;
                        gif.push(canvas).map_err(|e| p.file.named(e))?;
                        *pushed = Some(world.frame());
                    }
                }
                Target::Png { start, frozen } => {
                    if !*frozen && *start > 0 && world.len() * 2 <= *start {
                        p.painter.draw(world)?;
                        *frozen = true;
                    }
                }
            }
        }
        #[cfg(not(feature = "render"))]
        let _ = world;
        Ok(())
    }

    /// Flushes and closes everything and moves each complete file into place; an animation
    /// ends with the last frame, a PNG is the last frame unless it holds an earlier one.
    pub fn finish(mut self, world: &World) -> Result<()> {
        if let Some(t) = self.trajectories.take() {
            t.finish()?;
        }
        #[cfg(feature = "render")]
        if let Some(mut p) = self.picture.take() {
            match p.target {
                Target::Gif {
                    mut gif, pushed, ..
                } => {
                    if pushed != Some(world.frame()) {
                        let canvas = p.painter.draw(world)?;
                        gif.push(canvas).map_err(|e| p.file.named(e))?;
                    }
                    gif.finish().map_err(|e| p.file.named(e))?;
                }
                Target::Png { frozen, .. } => {
                    let canvas = if frozen {
                        p.painter.canvas()
                    } else {
                        p.painter.draw(world)?
                    };
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

    /// Observes the world's current frame and writes its row; the observation's time counts in
    /// the `stats` of the step that made the frame, when given.
    pub fn frame(&mut self, world: &World, stats: Option<&mut StepStats>) -> Result<()> {
        match stats {
            Some(stats) => self.recorder.observe_step(world, stats),
            None => self.recorder.observe(world),
        }
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
