//! Writing canvases to files: animated GIF (streamed frame by frame) and indexed PNG.
//!
//! Both formats take the canvas's palette indices as they are, so no colour quantisation happens.
//! A [`GifRecorder`] writes each frame to a buffered file as it is pushed, so memory use does not
//! grow with the number of frames; it loops forever. I/O failures become [`Error::Io`] naming the
//! file.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use super::canvas::check_size;
use super::{Canvas, Palette};
use crate::error::{Error, Result};

fn io_error(path: &str, source: std::io::Error) -> Error {
    Error::Io {
        path: path.to_string(),
        source,
    }
}

fn gif_error(path: &str, e: gif::EncodingError) -> Error {
    match e {
        gif::EncodingError::Io(source) => io_error(path, source),
        other => Error::Invalid {
            name: format!("GIF {path}"),
            reason: other.to_string(),
        },
    }
}

/// An animated GIF being written, one frame per [`GifRecorder::push`].
///
/// Frames use the global palette (the standard [`Palette`]); a canvas with another palette gets
/// it as a local colour table. Dropping a recorder without [`GifRecorder::finish`] still ends the
/// file, but errors at that point go unreported.
pub struct GifRecorder {
    encoder: gif::Encoder<BufWriter<File>>,
    path: String,
    width: u16,
    height: u16,
    delay_cs: u16,
    palette: Palette,
    frames: usize,
}

impl std::fmt::Debug for GifRecorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GifRecorder")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("delay_cs", &self.delay_cs)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

impl GifRecorder {
    /// Creates (or truncates) the file at `path` for a `width x height` animation showing each
    /// frame for `delay_cs` hundredths of a second, looping forever.
    ///
    /// # Errors
    /// [`Error::NotPositive`] or [`Error::OutOfRange`] for a side of 0 or over
    /// [`MAX_SIDE`](super::MAX_SIDE); [`Error::Io`] when the file cannot be created or written.
    pub fn create(path: impl AsRef<Path>, width: u32, height: u32, delay_cs: u16) -> Result<Self> {
        check_size(width, height)?;
        let shown = path.as_ref().display().to_string();
        let file = File::create(path.as_ref()).map_err(|e| io_error(&shown, e))?;
        let palette = Palette::standard();
        // `check_size` caps sides at 8192, which fits in u16.
        let (w, h) = (width as u16, height as u16);
        let mut encoder = gif::Encoder::new(BufWriter::new(file), w, h, &palette.to_bytes())
            .map_err(|e| gif_error(&shown, e))?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| gif_error(&shown, e))?;
        Ok(GifRecorder {
            encoder,
            path: shown,
            width: w,
            height: h,
            delay_cs,
            palette,
            frames: 0,
        })
    }

    /// Appends `canvas` as the next frame.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the canvas's size differs from the recorder's; [`Error::Io`] when
    /// writing fails.
    pub fn push(&mut self, canvas: &Canvas) -> Result<()> {
        if canvas.width() != u32::from(self.width) || canvas.height() != u32::from(self.height) {
            return Err(Error::Invalid {
                name: format!("GIF frame for {}", self.path),
                reason: format!(
                    "canvas is {} x {}, the animation is {} x {}",
                    canvas.width(),
                    canvas.height(),
                    self.width,
                    self.height
                ),
            });
        }
        let frame = gif::Frame {
            delay: self.delay_cs,
            width: self.width,
            height: self.height,
            palette: (canvas.palette() != &self.palette).then(|| canvas.palette().to_bytes()),
            buffer: std::borrow::Cow::Borrowed(canvas.pixels()),
            ..gif::Frame::default()
        };
        self.encoder
            .write_frame(&frame)
            .map_err(|e| gif_error(&self.path, e))?;
        self.frames += 1;
        Ok(())
    }

    /// How many frames have been pushed.
    #[must_use]
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Ends the file and flushes it to disk.
    ///
    /// # Errors
    /// [`Error::Io`] when writing fails.
    pub fn finish(self) -> Result<()> {
        let GifRecorder { encoder, path, .. } = self;
        let mut writer = encoder.into_inner().map_err(|e| gif_error(&path, e))?;
        writer.flush().map_err(|e| io_error(&path, e))?;
        Ok(())
    }
}

/// Writes `canvas` to `path` as an 8-bit indexed PNG in the canvas's palette.
///
/// # Errors
/// [`Error::Io`] when the file cannot be created or written.
pub fn write_png(canvas: &Canvas, path: impl AsRef<Path>) -> Result<()> {
    let shown = path.as_ref().display().to_string();
    let png_error = |e: png::EncodingError| match e {
        png::EncodingError::IoError(source) => io_error(&shown, source),
        other => Error::Invalid {
            name: format!("PNG {shown}"),
            reason: other.to_string(),
        },
    };
    let file = File::create(path.as_ref()).map_err(|e| io_error(&shown, e))?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), canvas.width(), canvas.height());
    encoder.set_color(png::ColorType::Indexed);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_palette(canvas.palette().to_bytes());
    let mut writer = encoder.write_header().map_err(png_error)?;
    writer
        .write_image_data(canvas.pixels())
        .map_err(png_error)?;
    writer.finish().map_err(png_error)?;
    Ok(())
}
