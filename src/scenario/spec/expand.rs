//! A scenario's `[layout]` written out: the generated walls, exits, field, measurement line
//! and spawn rectangles merged into the scenario's own keys ([`Scenario::expanded`]).

use glam::Vec2;

use super::{Scenario, Spawn};
use crate::error::{Error, Result};
use crate::scenario::layout::{SPAWN_DISTANCE, WALL_DISTANCE};

impl Scenario {
    /// This scenario with its `[layout]` written out as walls, exits, a field and spawn
    /// rectangles (itself when it has none).
    ///
    /// # Errors
    /// As [`Layout::validate`](crate::scenario::Layout::validate); [`Error::Invalid`] when the
    /// scenario has a layout with a field and a `[field]` of its own, or a group spawns in the
    /// layout without one.
    pub fn expanded(&self) -> Result<Scenario> {
        let Some(layout) = self.layout else {
            if self.groups.iter().any(|g| g.spawn == Spawn::Layout) {
                return Err(Error::Invalid {
                    name: "spawn".into(),
                    reason: "`kind = \"layout\"` needs a [layout] table".into(),
                });
            }
            return Ok(self.clone());
        };
        layout.validate()?;
        let e = layout.expand(self.agent_count())?;
        let mut s = self.clone();
        s.layout = None;
        s.obstacles.walls.extend(e.walls);
        s.exits.extend(e.exits);
        if let Some(f) = e.field {
            if s.field.is_some() {
                return Err(Error::Invalid {
                    name: "layout".into(),
                    reason: "a bottleneck layout brings its own field; remove [field]".into(),
                });
            }
            s.field = Some(f);
        }
        if let Some(line) = e.line
            && s.measurements.lines.iter().all(|l| l.name != line.name)
        {
            s.measurements.lines.push(line);
        }
        let m = Vec2::splat(WALL_DISTANCE);
        for g in &mut s.groups {
            if g.spawn == Spawn::Layout {
                g.spawn = Spawn::Spread {
                    min: e.spawn.0 + m,
                    max: e.spawn.1 - m,
                    distance: SPAWN_DISTANCE,
                };
            }
        }
        Ok(s)
    }
}
