//! A whole scenario moved by a motion of the plane that keeps axis-aligned lines axis-aligned (a
//! translation, a quarter turn, a mirror image): the invariance tests build the moved scene and
//! check that it moves as the original, moved.
//!
//! Every coordinate the scenario holds is mapped: spawn regions and points, goals, behaviour
//! targets and jump points, paths, target slots, obstacles (random ones drawn first and written
//! out), gravity points and their motion, the walkable area, exits, stages, the field's origin,
//! measurement lines and areas; a `[layout]` is written out first. What cannot be mapped is an
//! error that says why: a walled world's walls stand at `0` and its size, so it cannot be
//! translated, and it turns onto itself only about its centre (a square one) or mirrors only in
//! its middle; a torus likewise; a field raster other than the walkable area's (an ASCII map, a
//! generated cave) and goal cells given by index or drawn at random keep their orientation.

use glam::Vec2;

use super::fields::{GoalSpec, MapSource};
use super::spec::{AgentGoal, Scenario, Spawn, WorldKind};
use crate::error::{Error, Result};
use crate::gravity::Motion;
use crate::steering::{Behaviour, Target};

/// A motion of the plane that maps the lines of an axis-aligned grid onto such lines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PlaneMap {
    /// `p + offset`.
    Translate(Vec2),
    /// A quarter turn anticlockwise about `center`.
    Rotate90 {
        /// The fixed point.
        center: Vec2,
    },
    /// The mirror image in the vertical line `x = axis`.
    MirrorX {
        /// The line's x.
        axis: f32,
    },
}

impl PlaneMap {
    /// The image of the point `p`.
    #[must_use]
    pub fn point(&self, p: Vec2) -> Vec2 {
        match *self {
            PlaneMap::Translate(o) => p + o,
            PlaneMap::Rotate90 { center } => center + self.vector(p - center),
            PlaneMap::MirrorX { axis } => Vec2::new(2.0 * axis - p.x, p.y),
        }
    }

    /// The image of the displacement (or velocity) `v`.
    #[must_use]
    pub fn vector(&self, v: Vec2) -> Vec2 {
        match *self {
            PlaneMap::Translate(_) => v,
            PlaneMap::Rotate90 { .. } => Vec2::new(-v.y, v.x),
            PlaneMap::MirrorX { .. } => Vec2::new(-v.x, v.y),
        }
    }

    /// Whether the map reverses the sense of rotation.
    #[must_use]
    pub fn reflects(&self) -> bool {
        matches!(self, PlaneMap::MirrorX { .. })
    }

    /// The image of the axis-aligned rectangle `[min, max]`, as its lower and upper corner.
    fn rect(&self, min: Vec2, max: Vec2) -> (Vec2, Vec2) {
        let (a, b) = (self.point(min), self.point(max));
        (a.min(b), a.max(b))
    }

    /// Whether the map takes the world rectangle `[0, size]` onto itself.
    fn keeps(&self, size: Vec2) -> bool {
        let centre = size * 0.5;
        match *self {
            PlaneMap::Translate(o) => o == Vec2::ZERO,
            PlaneMap::Rotate90 { center } => size.x == size.y && center == centre,
            PlaneMap::MirrorX { axis } => axis == centre.x,
        }
    }

    fn target(&self, t: &mut Target) {
        if let Target::Point(p) = t {
            *p = self.point(*p);
        }
    }

    fn spawn(&self, spawn: &mut Spawn) {
        match spawn {
            Spawn::Rect { min, max } | Spawn::Spread { min, max, .. } => {
                (*min, *max) = self.rect(*min, *max);
            }
            Spawn::Disc { center, .. } | Spawn::Circle { center, .. } => {
                *center = self.point(*center);
            }
            Spawn::Points { points } => points.iter_mut().for_each(|p| *p = self.point(*p)),
            Spawn::Grid {
                origin,
                spacing,
                transpose,
                ..
            } => {
                *origin = self.point(*origin);
                // A quarter turn takes steps along x to steps along y: the rows swap axes.
                if let PlaneMap::Rotate90 { .. } = self {
                    *spacing = Vec2::new(-spacing.y, spacing.x);
                    *transpose = !*transpose;
                } else {
                    *spacing = self.vector(*spacing);
                }
            }
            Spawn::Uniform | Spawn::FreeCells | Spawn::Layout => {}
        }
    }

    fn area(&self, a: &crate::geometry::Walkable) -> Result<crate::geometry::Walkable> {
        a.mapped(|p| self.point(p))
    }
}

impl Scenario {
    /// This scenario with every coordinate mapped by `map` (see the module docs): the same scene
    /// translated, turned or mirrored, with its random obstacles and gravity points drawn first.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming what `map` cannot move (a walled world translated, a raster
    /// map turned); otherwise as [`Scenario::expanded`] and [`Scenario::validate`].
    pub fn transformed(&self, map: PlaneMap) -> Result<Scenario> {
        let cannot = |name: &str, reason: &str| Error::Invalid {
            name: name.into(),
            reason: reason.into(),
        };
        let mut s = self.expanded()?;
        let translation = matches!(map, PlaneMap::Translate(_));
        if s.world.kind == WorldKind::Bounded || (s.world.kind == WorldKind::Torus && !translation)
        {
            let size = s.bounds()?.size().unwrap_or(Vec2::ZERO);
            if !map.keeps(size) {
                return Err(cannot(
                    "world",
                    "a walled world stands at [0, size]: it is only turned about its centre \
                     (when square) and mirrored in its middle (a torus is also translated)",
                ));
            }
        }
        s.obstacles.materialise(s.seed)?;
        s.gravity.materialise(s.seed)?;
        for g in &mut s.groups {
            map.spawn(&mut g.spawn);
            if let Some(goal) = &mut g.goal {
                *goal = match *goal {
                    AgentGoal::Antipode { center } => AgentGoal::Antipode {
                        center: map.point(center),
                    },
                    AgentGoal::Point { point } => AgentGoal::Point {
                        point: map.point(point),
                    },
                    AgentGoal::Offset { by } => AgentGoal::Offset { by: map.vector(by) },
                };
            }
            for w in &mut g.params.steering.behaviours {
                if let Some(t) = w.behaviour.target_mut() {
                    map.target(t);
                }
                if let Behaviour::Jump {
                    launch, landing, ..
                } = &mut w.behaviour
                {
                    *launch = map.point(*launch);
                    *landing = map.point(*landing);
                }
            }
        }
        for p in &mut s.paths {
            let points = p.points().iter().map(|&q| map.point(q)).collect();
            *p = crate::group::Path::new(points, p.radius(), p.is_looped())?;
        }
        for t in &mut s.targets {
            t.position = map.point(t.position);
            t.velocity = map.vector(t.velocity);
        }
        let o = &mut s.obstacles;
        o.circles
            .iter_mut()
            .for_each(|c| c.center = map.point(c.center));
        for w in &mut o.walls {
            (w.a, w.b) = (map.point(w.a), map.point(w.b));
        }
        for p in &mut o.polygons {
            p.points.iter_mut().for_each(|q| *q = map.point(*q));
        }
        for p in &mut s.gravity.points {
            p.position = map.point(p.position);
            match &mut p.motion {
                Motion::Linear { velocity } => *velocity = map.vector(*velocity),
                Motion::Orbit {
                    center,
                    angular_speed,
                    ..
                } => {
                    *center = map.point(*center);
                    if map.reflects() {
                        *angular_speed = -*angular_speed;
                    }
                }
                Motion::Static | Motion::Agent { .. } => {}
            }
        }
        if let Some(f) = &mut s.field {
            if let PlaneMap::Translate(offset) = map {
                f.origin += offset;
            } else {
                if f.map != MapSource::Walkable {
                    return Err(cannot(
                        "field.map",
                        "a map raster other than the walkable area's keeps its orientation",
                    ));
                }
                if f.channels
                    .iter()
                    .any(|c| matches!(c, GoalSpec::Cells(_) | GoalSpec::Random(_)))
                {
                    return Err(cannot(
                        "field.channels",
                        "goal cells by index or drawn at random keep their orientation",
                    ));
                }
                f.origin = map.point(f.origin);
            }
        }
        for e in &mut s.exits {
            *e = match &e.polygon {
                Some(a) => crate::world::Exit::polygon(map.area(a)?),
                None => {
                    let (min, max) = map.rect(e.min, e.max);
                    crate::world::Exit::rect(min, max)
                }
            };
        }
        for (i, stage) in s.stages.iter_mut().enumerate() {
            stage.map(|p| map.point(p)).map_err(|e| Error::Invalid {
                name: format!("stages[{i}]"),
                reason: e.to_string(),
            })?;
        }
        for l in &mut s.measurements.lines {
            (l.from, l.to) = (map.point(l.from), map.point(l.to));
            if map.reflects() {
                // The mirror turns the line's left side to its right: swap the ends so that
                // crossings keep their sign.
                std::mem::swap(&mut l.from, &mut l.to);
            }
        }
        for a in &mut s.measurements.areas {
            let polygon = a.polygon.iter().map(|&q| map.point(q)).collect();
            *a = crate::measure::MeasurementArea::new(&a.name, polygon)?;
        }
        if let Some(g) = &mut s.geometry {
            g.walkable = map.area(&g.walkable)?;
        }
        s.validate()?;
        Ok(s)
    }
}
