//! Scaling by tiles (`world.scale = "tiles"`): `--agents N` lays copies of the whole scenario
//! side by side instead of crowding one copy, so density, squad sizes and neighbour counts stay
//! as in the file, the way `density` keeps a flock's.
//!
//! Invariants: copy `c` is the scenario with its agent share, shifted by its tile's corner;
//! every reference is rebased (group indices by `c x groups`, path indices by `c x paths`,
//! target slots by `c x targets` (each copy has its own slots, shifted with it),
//! agent ids by the agents of the copies before it); random obstacles and gravity points are
//! drawn per copy (from the seed and the copy's index) and written out as explicit ones; the
//! tiled scenario has the size of the tile grid and scales by counts from then on. A `[field]`
//! whose map covers the tile exactly is repeated with it: copy `c`'s cells hold the map, the
//! cells of the grid's tiles without a copy are walls, goal cells and walker groups are rebased
//! per copy, random goal counts multiplied by the copies.

use glam::Vec2;

use super::fields::{FieldSpec, GoalSpec, MapSource, WalkerSpec};
use super::group::Members;
use super::spec::{Scenario, Spawn, WorldScale};
use crate::agents::AgentId;
use crate::error::{Error, Result, try_reserve};
use crate::field::OccupancyGrid;
use crate::gravity::Motion;
use crate::group::PathId;
use crate::steering::{Behaviour, Target};

/// How one copy's references move.
struct Shift {
    offset: Vec2,
    groups: usize,
    paths: u32,
    targets: u32,
    agents: u32,
}

impl Shift {
    fn target(&self, t: &mut Target) {
        match t {
            Target::Point(p) => *p += self.offset,
            Target::Agent(id) => id.0 += self.agents,
            Target::Nearest { group, .. } => *group += self.groups,
            Target::Slot(s) => s.0 += self.targets,
            Target::Own => {}
        }
    }

    fn behaviour(&self, b: &mut Behaviour) {
        if let Some(t) = b.target_mut() {
            self.target(t);
        }
        match b {
            Behaviour::FollowPath { path, .. } => *path = PathId(path.0 + self.paths),
            Behaviour::Jump {
                launch, landing, ..
            } => {
                *launch += self.offset;
                *landing += self.offset;
            }
            _ => {}
        }
    }
}

impl Scenario {
    /// `total` agents as copies of this scenario on a grid of tiles (see the module docs).
    pub(crate) fn tiled(&self, total: usize) -> Result<Scenario> {
        let base = self.agent_count().max(1);
        let copies = ((total as f64 / base as f64).round() as usize).max(1);
        let mut plain = self.clone();
        plain.world.scale = WorldScale::Counts;
        if copies == 1 {
            return plain.with_agents(total);
        }
        let size = self.world.size.ok_or_else(|| Error::Invalid {
            name: "world.scale".into(),
            reason: "scaling by tiles needs a `size`".into(),
        })?;
        if self.layout.is_some() {
            return Err(Error::Invalid {
                name: "world.scale".into(),
                reason: "a scenario with a `[layout]` cannot scale by tiles".into(),
            });
        }
        if self.geometry.is_some() {
            return Err(Error::Invalid {
                name: "world.scale".into(),
                reason: "a scenario with a `[geometry]` cannot scale by tiles".into(),
            });
        }
        self.check_tiled(copies)?;
        let cols = (copies as f64).sqrt().ceil() as usize;
        let rows = copies.div_ceil(cols);
        let mut out = plain.clone();
        out.world.size = Some(size * Vec2::new(cols as f32, rows as f32));
        out.groups.clear();
        out.paths.clear();
        out.targets.clear();
        out.formations.clear();
        out.obstacles = Default::default();
        out.gravity = Default::default();
        out.exits.clear();
        // Sized by the agent count: an error, not an abort, when the process cannot hold the
        // copies (checked against its bound where known, and reserved fallibly).
        if let Some(ceiling) = crate::limits::memory_ceiling() {
            crate::limits::check_memory_under(
                "world.scale = \"tiles\"",
                (copies as u64).saturating_mul(plain.copy_bytes()),
                ceiling,
            )?;
        }
        let reserve = |n: usize| n.saturating_mul(copies);
        let what = "world.scale = \"tiles\"";
        try_reserve(&mut out.groups, reserve(plain.groups.len()), what)?;
        try_reserve(&mut out.paths, reserve(plain.paths.len()), what)?;
        try_reserve(&mut out.targets, reserve(plain.targets.len()), what)?;
        try_reserve(&mut out.formations, reserve(plain.formations.len()), what)?;
        try_reserve(&mut out.exits, reserve(plain.exits.len()), what)?;
        let o = &plain.obstacles;
        let random_circles = o.random_circles.as_ref().map_or(0, |r| r.count);
        try_reserve(
            &mut out.obstacles.circles,
            reserve(o.circles.len() + random_circles),
            what,
        )?;
        try_reserve(&mut out.obstacles.walls, reserve(o.walls.len()), what)?;
        try_reserve(&mut out.obstacles.polygons, reserve(o.polygons.len()), what)?;
        let random_points = plain.gravity.random.as_ref().map_or(0, |r| r.count);
        try_reserve(
            &mut out.gravity.points,
            reserve(plain.gravity.points.len() + random_points),
            what,
        )?;
        if let Some(f) = &self.field {
            out.field = Some(tiled_field(
                f,
                size,
                copies,
                cols,
                rows,
                plain.groups.len(),
            )?);
        }
        let mut agents = 0u32;
        for c in 0..copies {
            let share = total / copies + usize::from(c < total % copies);
            let mut copy = plain.clone().with_agents(share)?;
            let shift = Shift {
                offset: size * Vec2::new((c % cols) as f32, (c / cols) as f32),
                groups: c * plain.groups.len(),
                paths: (c * plain.paths.len()) as u32,
                targets: (c * plain.targets.len()) as u32,
                agents,
            };
            let seed = self.seed ^ (c as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            copy.obstacles.materialise(seed)?;
            copy.gravity.materialise(seed)?;
            for g in &mut copy.groups {
                match &mut g.spawn {
                    Spawn::Rect { min, max } | Spawn::Spread { min, max, .. } => {
                        *min += shift.offset;
                        *max += shift.offset;
                    }
                    Spawn::Disc { center, .. } | Spawn::Circle { center, .. } => {
                        *center += shift.offset;
                    }
                    Spawn::Grid { origin, .. } => *origin += shift.offset,
                    Spawn::Points { points } => points.iter_mut().for_each(|p| *p += shift.offset),
                    Spawn::Uniform => {
                        g.spawn = Spawn::Rect {
                            min: shift.offset,
                            max: shift.offset + size,
                        };
                    }
                    Spawn::FreeCells | Spawn::Layout => {}
                }
                if let Some(goal) = &mut g.goal {
                    goal.shift(shift.offset);
                }
                for w in &mut g.params.steering.behaviours {
                    shift.behaviour(&mut w.behaviour);
                }
            }
            for p in &copy.paths {
                let points = p.points().iter().map(|&q| q + shift.offset).collect();
                out.paths
                    .push(crate::group::Path::new(points, p.radius(), p.is_looped())?);
            }
            out.targets
                .extend(copy.targets.iter().map(|t| crate::targets::TargetPoint {
                    position: t.position + shift.offset,
                    ..*t
                }));
            for f in &mut copy.formations {
                f.anchor.agent = AgentId(f.anchor.agent.0 + agents);
                match &mut f.members {
                    Members::Group(g) => *g += shift.groups,
                    Members::Agents(ids) => ids.iter_mut().for_each(|id| id.0 += agents),
                }
            }
            let o = &mut copy.obstacles;
            o.circles.iter_mut().for_each(|k| k.center += shift.offset);
            for w in &mut o.walls {
                w.a += shift.offset;
                w.b += shift.offset;
            }
            for p in &mut o.polygons {
                p.points.iter_mut().for_each(|q| *q += shift.offset);
            }
            for e in &mut copy.exits {
                *e = match &e.polygon {
                    Some(a) => crate::world::Exit::polygon(a.translated(shift.offset)?),
                    None => crate::world::Exit::rect(e.min + shift.offset, e.max + shift.offset),
                };
            }
            for p in &mut copy.gravity.points {
                p.position += shift.offset;
                match &mut p.motion {
                    Motion::Orbit { center, .. } => *center += shift.offset,
                    Motion::Agent { agent } => agent.0 += agents,
                    _ => {}
                }
            }
            agents += copy.agent_count() as u32;
            out.groups.append(&mut copy.groups);
            out.formations.append(&mut copy.formations);
            out.obstacles.circles.append(&mut copy.obstacles.circles);
            out.obstacles.walls.append(&mut copy.obstacles.walls);
            out.obstacles.polygons.append(&mut copy.obstacles.polygons);
            out.gravity.points.append(&mut copy.gravity.points);
            out.exits.append(&mut copy.exits);
        }
        Ok(out)
    }
}

impl Scenario {
    /// The bytes one copy adds while tiling: its groups (at
    /// [`BYTES_PER_GROUP`](crate::limits::BYTES_PER_GROUP)), obstacles, gravity points, exits,
    /// paths and formations as listed (random ones drawn).
    fn copy_bytes(&self) -> u64 {
        use std::mem::size_of;
        let o = &self.obstacles;
        let circles = o.circles.len() + o.random_circles.as_ref().map_or(0, |r| r.count);
        let polygon_points: usize = o.polygons.iter().map(|p| p.points.len()).sum();
        let points =
            self.gravity.points.len() + self.gravity.random.as_ref().map_or(0, |r| r.count);
        let path_points: usize = self.paths.iter().map(|p| p.points().len()).sum();
        [
            self.groups.len() * crate::limits::BYTES_PER_GROUP as usize,
            circles * size_of::<crate::obstacles::Circle>(),
            o.walls.len() * size_of::<crate::obstacles::Wall>(),
            o.polygons.len() * size_of::<super::obstacles::PolygonSpec>()
                + polygon_points * size_of::<Vec2>(),
            points * size_of::<crate::gravity::GravityPoint>(),
            self.exits.len() * size_of::<crate::world::Exit>(),
            self.paths.len() * size_of::<crate::group::Path>() + path_points * size_of::<Vec2>(),
            self.formations.len() * size_of::<super::group::FormationSpec>(),
            self.targets.len() * size_of::<crate::targets::TargetPoint>(),
        ]
        .into_iter()
        .fold(0u64, |sum, b| sum.saturating_add(b as u64))
    }

    /// Refuses `copies` copies whose random obstacles, gravity points or random goals together
    /// pass their ceilings, before any copy is drawn: a ceiling applies to what is built.
    fn check_tiled(&self, copies: usize) -> Result<()> {
        use crate::limits::{MAX_GRAVITY_POINTS, MAX_RANDOM_CIRCLES, MAX_RANDOM_GOALS};
        let check = |name: &str, per_copy: usize, max: usize| -> Result<()> {
            let all = per_copy.saturating_mul(copies);
            if all <= max {
                return Ok(());
            }
            Err(Error::Invalid {
                name: name.into(),
                reason: format!(
                    "{per_copy} in each of the {copies} copies that `scale = \"tiles\"` lays for \
                     this agent count makes {all}, more than the ceiling of {max} (lower the \
                     count or the number of agents)"
                ),
            })
        };
        let random_circles = self
            .obstacles
            .random_circles
            .as_ref()
            .map_or(0, |r| r.count);
        check(
            "obstacles.random_circles.count",
            random_circles,
            MAX_RANDOM_CIRCLES,
        )?;
        let points =
            self.gravity.points.len() + self.gravity.random.as_ref().map_or(0, |r| r.count);
        check(
            "gravity points (points and random.count)",
            points,
            MAX_GRAVITY_POINTS,
        )?;
        if let Some(f) = &self.field {
            check("field.shuffle_goals", f.shuffle_goals, MAX_RANDOM_GOALS)?;
            for g in &f.channels {
                if let GoalSpec::Random(n) = g {
                    check("field.channels.random", *n, MAX_RANDOM_GOALS)?;
                }
            }
        }
        Ok(())
    }
}

/// `field` repeated for `copies` copies of a tile of `size` on `cols x rows` tiles (see the module
/// docs), for a scenario of `groups` groups per copy.
fn tiled_field(
    field: &FieldSpec,
    size: Vec2,
    copies: usize,
    cols: usize,
    rows: usize,
    groups: usize,
) -> Result<FieldSpec> {
    let refuse = |reason: String| Error::Invalid {
        name: "world.scale".into(),
        reason,
    };
    let map = match &field.map {
        MapSource::Ascii(text) => OccupancyGrid::parse_ascii(text, "<field.map.ascii>")?,
        MapSource::File(p) => OccupancyGrid::load_ascii(p)?,
        _ => {
            return Err(refuse(
                "a tiled `[field]` needs an ASCII map (`ascii` or `file`)".into(),
            ));
        }
    };
    let (w, h) = (map.grid.width() as usize, map.grid.height() as usize);
    let covered = Vec2::new(w as f32, h as f32) * field.cell_size;
    if (covered - size).abs().max_element() > 1e-3 * size.max_element() {
        return Err(refuse(format!(
            "a tiled `[field]`'s map must cover the tile exactly: {w} x {h} cells of {} cover \
             [{}, {}], the tile is [{}, {}]",
            field.cell_size, covered.x, covered.y, size.x, size.y
        )));
    }
    let cells = (cols * w) as u64 * (rows * h) as u64;
    if cells > crate::limits::MAX_CELLS {
        return Err(refuse(format!(
            "{copies} copies of the {w} x {h} map make a grid of {cells} cells, more than the \
             ceiling of {} (lower the number of agents or the map's size)",
            crate::limits::MAX_CELLS
        )));
    }
    let mut cell = vec![b'.'; w * h];
    for y in 0..h {
        for x in 0..w {
            if !map.grid.is_free(x as u32, y as u32) {
                cell[y * w + x] = b'#';
            }
        }
    }
    for &(x, y) in &map.goals {
        cell[y as usize * w + x as usize] = b'G';
    }
    for &(x, y) in &map.spawns {
        cell[y as usize * w + x as usize] = b'S';
    }
    let mut text = String::with_capacity((cols * w + 1) * rows * h);
    for r in 0..rows {
        for y in 0..h {
            for c in 0..cols {
                if r * cols + c < copies {
                    text.extend(cell[y * w..(y + 1) * w].iter().map(|&b| b as char));
                } else {
                    text.extend(std::iter::repeat_n('#', w));
                }
            }
            text.push('\n');
        }
    }
    let corner = |c: usize| (((c % cols) * w) as u32, ((c / cols) * h) as u32);
    let mut channels = Vec::with_capacity(field.channels.len());
    for g in &field.channels {
        channels.push(match g {
            GoalSpec::Map => GoalSpec::Map,
            GoalSpec::Cells(cells) => GoalSpec::Cells(
                (0..copies)
                    .flat_map(|c| {
                        let (dx, dy) = corner(c);
                        cells.iter().map(move |&(x, y)| (x + dx, y + dy))
                    })
                    .collect(),
            ),
            GoalSpec::Random(n) => GoalSpec::Random(n.saturating_mul(copies)),
            GoalSpec::Exit(_) => {
                return Err(refuse(
                    "a tiled `[field]` cannot have `exit` channels (every copy has its own exits)"
                        .into(),
                ));
            }
        });
    }
    Ok(FieldSpec {
        map: MapSource::Ascii(text),
        channels,
        shuffle_goals: field.shuffle_goals.saturating_mul(copies),
        walkers: (0..copies)
            .flat_map(|c| {
                field.walkers.iter().map(move |w| WalkerSpec {
                    group: w.group + c * groups,
                    ..w.clone()
                })
            })
            .collect(),
        ..field.clone()
    })
}
