//! Streaming outputs of a run: trajectory CSV rows (and pictures, with the `render` feature).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use throng::{Error, Result, World};

/// The files a run writes as it goes.
#[derive(Debug, Default)]
pub struct Outputs {
    csv: Option<(BufWriter<File>, String)>,
}

fn io_err(path: &str) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_string(),
        source,
    }
}

impl Outputs {
    /// Opens the requested files (nothing is written for an option that is `None`).
    pub fn open(
        render: Option<&Path>,
        trajectories: Option<&Path>,
        _world: &World,
    ) -> Result<Self> {
        if let Some(p) = render {
            return Err(Error::Invalid {
                name: "render".into(),
                reason: format!("{}: rendering is not available in this build", p.display()),
            });
        }
        let csv = match trajectories {
            Some(p) => {
                let name = p.display().to_string();
                let f = File::create(p).map_err(io_err(&name))?;
                let mut w = BufWriter::new(f);
                writeln!(w, "frame,t,id,x,y,vx,vy,heading").map_err(io_err(&name))?;
                Some((w, name))
            }
            None => None,
        };
        Ok(Outputs { csv })
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
        Ok(())
    }

    /// Flushes and closes everything.
    pub fn finish(mut self, _world: &World) -> Result<()> {
        if let Some((mut w, name)) = self.csv.take() {
            w.flush().map_err(io_err(&name))?;
        }
        Ok(())
    }
}
