//! Pedestrian layouts (`[layout]`): the geometry of the standard pedestrian experiments,
//! generated from a few keys so that a scenario can state `width = 1.2` instead of listing
//! walls, exits and a navigation map.
//!
//! - `kind = "corridor"`: a corridor `width` metres wide (default 10) whose length grows with
//!   the agent count so that the crowd's density stays `density` persons/m^2 (default 1):
//!   `length = max(min_length, N / (density * width)) + 2 margin` (defaults 100 m and 1.5 m),
//!   walled on all four sides, with a 1 m exit at each end. Agents spawn in `[margin, length -
//!   margin] x [0, width]`. This is the bidirectional corridor of the JuPedSim peer.
//! - `kind = "bottleneck"`: a room `room` (default 10 x 10 m) with, centred on its right wall,
//!   an exit corridor `width` metres wide (default 1.2) and `length` metres long (default 4),
//!   whose last 0.5 m is the exit. Agents spawn in the room. The layout adds a flow field (cells
//!   of 0.1 m, goal: the exit) for groups to follow with `follow_field`, and the measurement
//!   line `entrance` across the corridor's mouth (unless the scenario names a line so).
//!
//! Groups with `spawn = { kind = "layout" }` spawn in the layout's area, at least 0.45 m apart
//! and 0.25 m from the walls (as JuPedSim's `distribute_by_number` places them).
//!
//! Invariants: the expansion is a plain scenario (walls, exits, field, spawn rectangles), so
//! everything downstream treats a layout like keys written out by hand.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::fields::FieldSpec;
use crate::error::{Error, Result, in_range, positive};
use crate::obstacles::Wall;
use crate::world::Exit;

/// The distance between agents placed by a layout, m.
pub const SPAWN_DISTANCE: f32 = 0.45;
/// The distance between placed agents and the walls, m.
pub const WALL_DISTANCE: f32 = 0.25;
/// The longest side a layout may have, m.
pub const MAX_SIDE: f32 = 1e6;

/// A generated pedestrian geometry.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Layout {
    /// A walled corridor whose length grows with the agent count.
    Corridor {
        /// Width, m (> 0). Default: 10.
        #[serde(default = "ten")]
        width: f32,
        /// Persons per m^2 in the spawn area (> 0). Default: 1.
        #[serde(default = "one")]
        density: f32,
        /// Free length at each end, m (>= 1, the exits' depth). Default: 1.5.
        #[serde(default = "margin")]
        margin: f32,
        /// The shortest spawn length, m (> 0). Default: 100.
        #[serde(default = "hundred")]
        min_length: f32,
    },
    /// A room with an exit corridor on its right wall.
    Bottleneck {
        /// The exit corridor's width, m (> 0, at most the room's height). Default: 1.2.
        #[serde(default = "width")]
        width: f32,
        /// The room's width and height, m (> 0). Default: `[10, 10]`.
        #[serde(default = "room")]
        room: Vec2,
        /// The exit corridor's length, m (>= 0.5). Default: 4.
        #[serde(default = "four")]
        length: f32,
    },
}

impl Layout {
    /// Sets the corridor's or the bottleneck's width, m (checked when the scenario is
    /// expanded).
    pub fn set_width(&mut self, value: f32) {
        match self {
            Layout::Corridor { width, .. } | Layout::Bottleneck { width, .. } => *width = value,
        }
    }
}

fn ten() -> f32 {
    10.0
}
fn one() -> f32 {
    1.0
}
fn margin() -> f32 {
    1.5
}
fn hundred() -> f32 {
    100.0
}
fn width() -> f32 {
    1.2
}
fn room() -> Vec2 {
    Vec2::splat(10.0)
}
fn four() -> f32 {
    4.0
}

/// What a layout adds to a scenario.
pub(crate) struct Expansion {
    /// The walls, around the area and along the corridors.
    pub walls: Vec<Wall>,
    /// The exits.
    pub exits: Vec<Exit>,
    /// The spawn area's lower and upper corners.
    pub spawn: (Vec2, Vec2),
    /// The navigation field, when the layout brings one.
    pub field: Option<FieldSpec>,
    /// The measurement line, when the layout brings one.
    pub line: Option<crate::measure::MeasurementLine>,
}

impl Layout {
    /// Checks the keys.
    ///
    /// # Errors
    /// [`Error::NotPositive`], [`Error::NonFinite`], [`Error::OutOfRange`] or
    /// [`Error::Invalid`] naming the key (`layout.width`, ...).
    pub fn validate(&self) -> Result<()> {
        let side = |name: &'static str, v: f32| -> Result<()> {
            positive(name, v)?;
            in_range(name, v, 0.0, MAX_SIDE, "(0, 1e6] m")?;
            Ok(())
        };
        match *self {
            Layout::Corridor {
                width,
                density,
                margin,
                min_length,
            } => {
                side("layout.width", width)?;
                side("layout.density", density)?;
                side("layout.margin", margin)?;
                side("layout.min_length", min_length)?;
                if margin < 1.0 {
                    return Err(Error::Invalid {
                        name: "layout.margin".into(),
                        reason: format!("must be at least 1 m (the exits' depth), got {margin}"),
                    });
                }
            }
            Layout::Bottleneck {
                width,
                room,
                length,
            } => {
                side("layout.width", width)?;
                side("layout.room", room.x)?;
                side("layout.room", room.y)?;
                side("layout.length", length)?;
                if width > room.y {
                    return Err(Error::Invalid {
                        name: "layout.width".into(),
                        reason: format!("{width} m is wider than the room ({} m)", room.y),
                    });
                }
                if length < 0.5 {
                    return Err(Error::Invalid {
                        name: "layout.length".into(),
                        reason: format!("must be at least 0.5 m (the exit's depth), got {length}"),
                    });
                }
                if (room.x + length) * room.y > 4e6 {
                    return Err(Error::Invalid {
                        name: "layout.room".into(),
                        reason: "the navigation map would exceed 400 million cells of 0.1 m".into(),
                    });
                }
            }
        }
        Ok(())
    }

    /// The corridor's length for `agents` agents, m.
    fn corridor_length(agents: usize, width: f32, density: f32, margin: f32, min: f32) -> f32 {
        (agents as f32 / (density * width)).max(min) + 2.0 * margin
    }

    /// What this layout adds to a scenario of `agents` agents (its size may grow with them).
    pub(crate) fn expand(&self, agents: usize) -> Result<Expansion> {
        let wall = |a: Vec2, b: Vec2| Wall { a, b };
        Ok(match *self {
            Layout::Corridor {
                width,
                density,
                margin,
                min_length,
            } => {
                let l = Self::corridor_length(agents, width, density, margin, min_length);
                if l > MAX_SIDE {
                    return Err(Error::OutOfRange {
                        name: "layout",
                        value: f64::from(l),
                        range: "a corridor of at most 1e6 m (lower the agent count or raise the density)",
                    });
                }
                let (p00, p10, p11, p01) = (
                    Vec2::ZERO,
                    Vec2::new(l, 0.0),
                    Vec2::new(l, width),
                    Vec2::new(0.0, width),
                );
                Expansion {
                    walls: vec![
                        wall(p00, p10),
                        wall(p10, p11),
                        wall(p11, p01),
                        wall(p01, p00),
                    ],
                    exits: vec![
                        Exit::rect(p00, Vec2::new(1.0, width)),
                        Exit::rect(Vec2::new(l - 1.0, 0.0), p11),
                    ],
                    spawn: (Vec2::new(margin, 0.0), Vec2::new(l - margin, width)),
                    field: None,
                    line: None,
                }
            }
            Layout::Bottleneck {
                width,
                room,
                length,
            } => {
                let (w, h) = (room.x, room.y);
                let (y0, y1) = (0.5 * (h - width), 0.5 * (h + width));
                let end = w + length;
                let p = Vec2::new;
                let walls = vec![
                    wall(p(0.0, 0.0), p(w, 0.0)),
                    wall(p(w, 0.0), p(w, y0)),
                    wall(p(w, y0), p(end, y0)),
                    wall(p(end, y0), p(end, y1)),
                    wall(p(end, y1), p(w, y1)),
                    wall(p(w, y1), p(w, h)),
                    wall(p(w, h), p(0.0, h)),
                    wall(p(0.0, h), p(0.0, 0.0)),
                ];
                let exit = Exit::rect(p(end - 0.5, y0), p(end, y1));
                Expansion {
                    walls,
                    exits: vec![exit],
                    spawn: (Vec2::ZERO, room),
                    field: Some(bottleneck_field(w, h, y0, y1, end)),
                    line: Some(crate::measure::MeasurementLine {
                        name: "entrance".into(),
                        from: p(w, y0),
                        to: p(w, y1),
                    }),
                }
            }
        })
    }
}

/// The bottleneck's navigation map: cells of 0.1 m, free inside the room and the corridor,
/// goals in the exit.
fn bottleneck_field(w: f32, h: f32, y0: f32, y1: f32, end: f32) -> FieldSpec {
    const CELL: f32 = 0.1;
    const CLEARANCE: f32 = 0.15;
    let cols = (end / CELL).ceil() as usize;
    let rows = (h / CELL).ceil() as usize;
    let mut text = String::with_capacity((cols + 1) * rows);
    for y in 0..rows {
        let cy = (y as f32 + 0.5) * CELL;
        for x in 0..cols {
            let cx = (x as f32 + 0.5) * CELL;
            let in_corridor = cx > w && cx < end && cy > y0 && cy < y1;
            // Cells whose centre lies within CLEARANCE of the mouth's corners are walls, so
            // that routes keep the bodies off the corners (an agent's centre never comes that
            // close to a wall).
            let near_corner = [Vec2::new(w, y0), Vec2::new(w, y1)]
                .iter()
                .any(|c| c.distance(Vec2::new(cx, cy)) < CLEARANCE);
            let c = if near_corner {
                '#'
            } else if cx < w && cy < h {
                '.'
            } else if in_corridor && cx >= end - 0.5 {
                'G'
            } else if in_corridor {
                '.'
            } else {
                '#'
            };
            text.push(c);
        }
        text.push('\n');
    }
    FieldSpec::inline(text, CELL)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::MapSource;

    #[test]
    fn corridor_grows_with_the_agent_count() {
        let c = Layout::Corridor {
            width: 10.0,
            density: 1.0,
            margin: 1.5,
            min_length: 100.0,
        };
        let small = c.expand(1000).unwrap();
        assert_eq!(small.walls[0].b.x, 103.0);
        let big = c.expand(10_000).unwrap();
        assert_eq!(big.walls[0].b.x, 1003.0);
        assert_eq!(big.exits[1].min.x, 1002.0);
        assert_eq!(big.spawn.1, Vec2::new(1001.5, 10.0));
    }

    #[test]
    fn bottleneck_has_a_gap_of_the_width_and_a_map_with_goals() {
        let b = Layout::Bottleneck {
            width: 1.2,
            room: Vec2::splat(10.0),
            length: 4.0,
        };
        let e = b.expand(200).unwrap();
        assert_eq!(e.walls[1].b, Vec2::new(10.0, 4.4));
        assert_eq!(e.walls[5].a, Vec2::new(10.0, 5.6));
        let f = e.field.unwrap();
        let MapSource::Ascii(text) = &f.map else {
            panic!("inline map expected")
        };
        assert!(text.contains('G'));
        assert_eq!(text.lines().count(), 100);
        assert!(text.lines().all(|l| l.len() == 140));
        let bad = Layout::Bottleneck {
            width: 11.0,
            room: Vec2::splat(10.0),
            length: 4.0,
        };
        assert!(bad.validate().is_err());
    }
}
