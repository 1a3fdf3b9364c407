//! The recorder: fed the world after every step, it finds each agent's line crossings, counts
//! the agents in each area, and keeps running sums for the summary.
//!
//! Each observation pairs every agent's position with its position at the previous observation
//! (kept by [`AgentId`], so storage order and reordering do not matter); agents that left
//! through an exit in between are paired through [`World::departures`]. On a torus the move is
//! the minimum-image displacement, tested from the old position and, when it wrapped, also
//! towards the new one (at most one crossing per line and move). The frame's crossings are
//! sorted by time, then id, then line, before any sum sees them.

use std::time::Instant;

use glam::{DVec2, Vec2};
use serde::Serialize;

use super::MeasurementSpec;
use crate::agents::AgentId;
use crate::bounds::Bounds;
use crate::error::Result;
use crate::world::{StepStats, World};

/// One crossing of a line by an agent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// The line's index in [`MeasurementSpec::lines`].
    pub line: usize,
    /// The agent.
    pub id: AgentId,
    /// World time of the crossing, interpolated along the move, seconds.
    pub time: f64,
    /// +1 for the line's positive direction, -1 for the other.
    pub sign: i8,
}

/// An area's values in the latest observed frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AreaFrame {
    /// Agents inside.
    pub count: usize,
    /// Classic density: `count` over the area, agents per square unit.
    pub density: f64,
    /// Mean speed of the agents inside (`None` when nobody is inside).
    pub mean_speed: Option<f64>,
    /// The Voronoi density and speed ([`super::voronoi`]; `None` unless the spec asks for
    /// them and the world has a walkable area or walled bounds).
    pub voronoi: Option<super::voronoi::VoronoiFrame>,
}

/// A line's summary over the time window (the `lines` entries of `throng bench --json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LineReport {
    /// Time of the first crossing (`null` when none).
    pub first_time: Option<f64>,
    /// Flow `J = (N - 1) / (t_N - t_1)`, agents per second (`null` for fewer than two crossings
    /// or no time between them).
    pub flow: Option<f64>,
    /// Time of the last crossing (`null` when none).
    pub last_time: Option<f64>,
    /// The line's length `b`.
    pub length: f64,
    /// The line's name.
    pub name: String,
    /// Crossings in the negative direction.
    pub negative: u64,
    /// `positive - negative`.
    pub net: i64,
    /// Crossings in the positive direction.
    pub positive: u64,
    /// Agents whose first crossing of the line (either way) fell in the window: the count of
    /// the N-t diagram at the window's end, as PedPy's `compute_n_t` counts (each pedestrian
    /// once, at its first crossing).
    pub nt_count: u64,
    /// The flow of the N-t diagram, `(N - 1) / (t_N - t_1)` over those first crossings, agents
    /// per second (`null` for fewer than two or no time between them). Unlike `flow`, an agent
    /// that crosses back and again counts once: it is the flow researchers measure.
    pub nt_flow: Option<f64>,
    /// Specific flow `J / b`, agents per second and unit of length (`null` with `flow`).
    pub specific_flow: Option<f64>,
    /// Mean time gap between consecutive crossings (`null` for fewer than two crossings).
    pub time_gap_mean: Option<f64>,
    /// Sample standard deviation of the time gaps (`null` for fewer than two gaps).
    pub time_gap_sd: Option<f64>,
    /// All crossings: `positive + negative`.
    pub total: u64,
}

impl LineReport {
    /// The keys whose value may be `null` (formats without a null value drop them).
    pub const OPTIONAL_KEYS: [&'static str; 7] = [
        "first_time",
        "flow",
        "last_time",
        "nt_flow",
        "specific_flow",
        "time_gap_mean",
        "time_gap_sd",
    ];
}

/// An area's summary over the time window (the `areas` entries of `throng bench --json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct AreaReport {
    /// The polygon's area.
    pub area: f64,
    /// Frames observed in the window.
    pub frames: u64,
    /// Mean over those frames of the agents inside (`null` without frames).
    pub mean_count: Option<f64>,
    /// Mean over those frames of the classic density (`null` without frames).
    pub mean_density: Option<f64>,
    /// Mean over the frames with somebody inside of the mean speed (`null` when nobody was).
    pub mean_speed: Option<f64>,
    /// Mean over the frames of the Voronoi density (`null` unless measured).
    pub mean_voronoi_density: Option<f64>,
    /// Mean over the frames of the Voronoi speed (`null` unless measured).
    pub mean_voronoi_speed: Option<f64>,
    /// The area's name.
    pub name: String,
}

impl AreaReport {
    /// The keys whose value may be `null` (formats without a null value drop them).
    pub const OPTIONAL_KEYS: [&'static str; 5] = [
        "mean_count",
        "mean_density",
        "mean_speed",
        "mean_voronoi_density",
        "mean_voronoi_speed",
    ];
}

/// What a run's measurements found (the `measurements` object of `throng bench --json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MeasurementReport {
    /// One summary per area, in the scenario's order.
    pub areas: Vec<AreaReport>,
    /// Agents that left through an exit while observed.
    pub left: u64,
    /// One summary per line, in the scenario's order.
    pub lines: Vec<LineReport>,
}

/// Running count, mean and squared deviations (Welford).
#[derive(Clone, Copy, Debug, Default)]
struct Spread {
    n: u64,
    mean: f64,
    m2: f64,
}

impl Spread {
    fn push(&mut self, x: f64) {
        self.n += 1;
        let delta = x - self.mean;
        self.mean += delta / self.n as f64;
        self.m2 += delta * (x - self.mean);
    }

    fn mean(&self) -> Option<f64> {
        (self.n > 0).then_some(self.mean)
    }

    fn sample_sd(&self) -> Option<f64> {
        (self.n > 1).then(|| (self.m2 / (self.n - 1) as f64).sqrt())
    }
}

/// A line's counts: over the whole run, and the window's statistics.
#[derive(Clone, Copy, Debug, Default)]
struct LineTally {
    /// Whole-run cumulative counts (the CSV columns).
    positive: u64,
    negative: u64,
    /// In the window.
    window_positive: u64,
    window_negative: u64,
    first: Option<f64>,
    last: f64,
    gaps: Spread,
    /// The N-t diagram in the window: first crossings counted, the first and last of their
    /// times.
    nt_count: u64,
    nt_first: Option<f64>,
    nt_last: f64,
}

/// An area's running sums over the window's frames.
#[derive(Clone, Copy, Debug, Default)]
struct AreaTally {
    frames: u64,
    sum_count: f64,
    sum_density: f64,
    speed_frames: u64,
    sum_speed: f64,
    voronoi_frames: u64,
    sum_voronoi_density: f64,
    sum_voronoi_speed: f64,
}

/// The recorder of a run's measurements (see the [module docs](super)).
#[derive(Clone, Debug)]
pub struct Measurements {
    spec: MeasurementSpec,
    /// Per area: its size and bounding box.
    sizes: Vec<f64>,
    boxes: Vec<(Vec2, Vec2)>,
    lines: Vec<LineTally>,
    areas: Vec<AreaTally>,
    frame_areas: Vec<AreaFrame>,
    /// By agent id: the position at the observation `seen[id]` (1-based; 0: never).
    prev: Vec<Vec2>,
    seen: Vec<u64>,
    observations: u64,
    /// Frame and time of the latest observation.
    last: Option<(u64, f64)>,
    crossings: Vec<Crossing>,
    /// Per line, by agent id: whether the agent has crossed it (the N-t diagram's first
    /// crossings).
    crossed: Vec<Vec<bool>>,
    left: u64,
    last_exit_time: Option<f64>,
    has_exits: bool,
    inside: usize,
}

impl Measurements {
    /// A recorder for `spec`'s lines and areas (an empty spec still records exits).
    ///
    /// # Errors
    /// As [`MeasurementSpec::validate`].
    pub fn new(spec: &MeasurementSpec) -> Result<Self> {
        spec.validate()?;
        Ok(Measurements {
            sizes: spec
                .areas
                .iter()
                .map(super::MeasurementArea::area)
                .collect(),
            boxes: spec
                .areas
                .iter()
                .map(super::MeasurementArea::bounding_box)
                .collect(),
            lines: vec![LineTally::default(); spec.lines.len()],
            areas: vec![AreaTally::default(); spec.areas.len()],
            frame_areas: vec![AreaFrame::default(); spec.areas.len()],
            spec: spec.clone(),
            prev: Vec::new(),
            seen: Vec::new(),
            observations: 0,
            last: None,
            crossings: Vec::new(),
            crossed: vec![Vec::new(); spec.lines.len()],
            left: 0,
            last_exit_time: None,
            has_exits: false,
            inside: 0,
        })
    }

    /// What is measured.
    #[must_use]
    pub fn spec(&self) -> &MeasurementSpec {
        &self.spec
    }

    /// Observes the world's current frame after the step that `stats` reports, and counts the
    /// time it took in that step's [`measure`](crate::world::PhaseTimes::measure) phase and
    /// total, so that a step's reported time includes what measuring it cost.
    pub fn observe_step(&mut self, world: &World, stats: &mut StepStats) {
        let start = Instant::now();
        self.observe(world);
        let took = start.elapsed();
        stats.phases.measure += took;
        stats.total += took;
    }

    /// Observes the world's current frame: call it once before the first step and after every
    /// step. A second call at the same frame does nothing; after skipped steps, each agent's
    /// moves since its last observation count as one straight move (and only the latest step's
    /// departures are seen).
    pub fn observe(&mut self, world: &World) {
        let (frame, time) = (world.frame(), world.time());
        if self.last.is_some_and(|(f, _)| f == frame) {
            return;
        }
        let agents = world.agents();
        let before = self.observations;
        let now = before + 1;
        self.crossings.clear();
        // Each agent's last position matters only to the lines it may cross.
        let tracks = !self.spec.lines.is_empty();
        let ids = if !tracks {
            0
        } else {
            agents
                .ids()
                .iter()
                .chain(world.departures().iter().map(|d| &d.id))
                .map(|id| id.0 as usize + 1)
                .max()
                .unwrap_or(0)
        };
        if self.prev.len() < ids {
            self.prev.resize(ids, Vec2::ZERO);
            self.seen.resize(ids, 0);
        }
        if let Some((_, t0)) = self.last {
            let bounds = world.bounds();
            let live = (0..agents.len()).map(|i| (agents.id(i), agents.position(i)));
            let gone = world.departures().iter().map(|d| (d.id, d.position));
            if tracks {
                for (id, q) in live.chain(gone) {
                    let k = id.0 as usize;
                    if before > 0 && self.seen[k] == before {
                        self.cross(id, self.prev[k], q, (t0, time), bounds);
                    }
                }
            }
            let departed = world.departures().len();
            self.left += departed as u64;
            if departed > 0 {
                self.last_exit_time = Some(time);
            }
        }
        if tracks {
            for i in 0..agents.len() {
                let k = agents.id(i).0 as usize;
                self.prev[k] = agents.position(i);
                self.seen[k] = now;
            }
        }
        self.crossings.sort_by(|a, b| {
            a.time
                .total_cmp(&b.time)
                .then(a.id.cmp(&b.id))
                .then(a.line.cmp(&b.line))
        });
        let in_window = |t: f64| self.spec.window.is_none_or(|[t0, t1]| t >= t0 && t <= t1);
        for c in &self.crossings {
            let tally = &mut self.lines[c.line];
            if c.sign > 0 {
                tally.positive += 1;
            } else {
                tally.negative += 1;
            }
            let crossed = &mut self.crossed[c.line];
            let k = c.id.0 as usize;
            if crossed.len() <= k {
                crossed.resize(ids.max(k + 1), false);
            }
            let first = !crossed[k];
            crossed[k] = true;
            if !in_window(c.time) {
                continue;
            }
            if first {
                tally.nt_count += 1;
                tally.nt_first.get_or_insert(c.time);
                tally.nt_last = c.time;
            }
            if c.sign > 0 {
                tally.window_positive += 1;
            } else {
                tally.window_negative += 1;
            }
            if tally.first.is_some() {
                tally.gaps.push(c.time - tally.last);
            } else {
                tally.first = Some(c.time);
            }
            tally.last = c.time;
        }
        self.observe_areas(world, in_window(time));
        self.observations = now;
        self.last = Some((frame, time));
        self.has_exits = !world.exits().is_empty() || world.has_exit_stage();
        self.inside = world.len();
    }

    /// Records the crossings of the move `p -> q` over the times `(t0, t1)`.
    fn cross(&mut self, id: AgentId, p: Vec2, q: Vec2, (t0, t1): (f64, f64), bounds: Bounds) {
        let d = bounds.offset(p, q);
        let wrapped = bounds.is_torus() && p + d != q;
        let (p, q, d) = (p.as_dvec2(), q.as_dvec2(), d.as_dvec2());
        for (line, l) in self.spec.lines.iter().enumerate() {
            let cut = l
                .cut(p, p + d)
                .or_else(|| wrapped.then(|| l.cut(q - d, q)).flatten());
            if let Some(c) = cut {
                self.crossings.push(Crossing {
                    line,
                    id,
                    time: (t0 + c.at * (t1 - t0)).min(t1),
                    sign: c.sign,
                });
            }
        }
    }

    /// Counts the agents in each area and their mean speed; adds the frame to the window's
    /// sums when `counted`.
    fn observe_areas(&mut self, world: &World, counted: bool) {
        let agents = world.agents();
        let cells = self.voronoi_input(world);
        for (k, area) in self.spec.areas.iter().enumerate() {
            let (lo, hi) = self.boxes[k];
            let (mut count, mut speed) = (0usize, 0.0f64);
            for i in 0..agents.len() {
                let p = agents.position(i);
                if p.cmplt(lo).any() || p.cmpgt(hi).any() || !area.contains(p) {
                    continue;
                }
                count += 1;
                speed +=
                    DVec2::new(f64::from(agents.vel_x()[i]), f64::from(agents.vel_y()[i])).length();
            }
            let voronoi = cells.as_ref().map(|(points, speeds, region)| {
                let ring: Vec<DVec2> = area.polygon.iter().map(|p| p.as_dvec2()).collect();
                super::voronoi::voronoi_frame(points, speeds, region, &ring)
            });
            let frame = AreaFrame {
                count,
                density: count as f64 / self.sizes[k],
                mean_speed: (count > 0).then(|| speed / count as f64),
                voronoi,
            };
            self.frame_areas[k] = frame;
            if counted {
                let t = &mut self.areas[k];
                t.frames += 1;
                t.sum_count += count as f64;
                t.sum_density += frame.density;
                if let Some(v) = frame.mean_speed {
                    t.speed_frames += 1;
                    t.sum_speed += v;
                }
                if let Some(v) = frame.voronoi {
                    t.voronoi_frames += 1;
                    t.sum_voronoi_density += v.density;
                    t.sum_voronoi_speed += v.speed;
                }
            }
        }
    }

    /// The positions, speeds and walkable region for the Voronoi cells, when the spec asks for
    /// them and the world has a walkable area or walled bounds.
    fn voronoi_input(
        &self,
        world: &World,
    ) -> Option<(Vec<DVec2>, Vec<f64>, super::voronoi::Region)> {
        if !self.spec.voronoi || self.spec.areas.is_empty() {
            return None;
        }
        let region = match (world.walkable(), world.bounds()) {
            (Some(w), _) => super::voronoi::Region::of(w),
            (None, Bounds::Bounded { size }) => {
                super::voronoi::Region::rectangle(DVec2::ZERO, size.as_dvec2())
            }
            _ => return None,
        };
        let a = world.agents();
        let points = (0..a.len()).map(|i| a.position(i).as_dvec2()).collect();
        let speeds = (0..a.len())
            .map(|i| DVec2::new(f64::from(a.vel_x()[i]), f64::from(a.vel_y()[i])).length())
            .collect();
        Some((points, speeds, region))
    }

    /// The crossings found by the latest observation, sorted by time, then agent id, then
    /// line.
    #[must_use]
    pub fn crossings(&self) -> &[Crossing] {
        &self.crossings
    }

    /// Per line, the cumulative `(positive, negative)` crossings of the whole run so far.
    pub fn line_counts(&self) -> impl Iterator<Item = (u64, u64)> + '_ {
        self.lines.iter().map(|t| (t.positive, t.negative))
    }

    /// Per area, its values in the latest observed frame.
    #[must_use]
    pub fn area_frames(&self) -> &[AreaFrame] {
        &self.frame_areas
    }

    /// Agents that left through an exit while observed.
    #[must_use]
    pub fn left(&self) -> u64 {
        self.left
    }

    /// Agents in the world at the latest observation.
    #[must_use]
    pub fn inside(&self) -> usize {
        self.inside
    }

    /// Whether the world had exits or exit stages at the latest observation.
    #[must_use]
    pub fn has_exits(&self) -> bool {
        self.has_exits
    }

    /// The time at which the last agent left through an exit (or an exit stage): `Some` only
    /// when the world has exits or exit stages, is empty, and somebody left while observed.
    #[must_use]
    pub fn evacuation_time(&self) -> Option<f64> {
        if self.has_exits && self.inside == 0 {
            self.last_exit_time
        } else {
            None
        }
    }

    /// The summary of everything observed so far.
    #[must_use]
    pub fn report(&self) -> MeasurementReport {
        let lines = self
            .spec
            .lines
            .iter()
            .zip(&self.lines)
            .map(|(l, t)| {
                let total = t.window_positive + t.window_negative;
                let length = l.length();
                let span = t.first.map(|first| t.last - first);
                let flow = span
                    .filter(|&s| total > 1 && s > 0.0)
                    .map(|s| (total - 1) as f64 / s);
                let nt_flow = t
                    .nt_first
                    .map(|first| t.nt_last - first)
                    .filter(|&s| t.nt_count > 1 && s > 0.0)
                    .map(|s| (t.nt_count - 1) as f64 / s);
                LineReport {
                    first_time: t.first,
                    flow,
                    nt_count: t.nt_count,
                    nt_flow,
                    last_time: t.first.map(|_| t.last),
                    length,
                    name: l.name.clone(),
                    negative: t.window_negative,
                    net: t.window_positive as i64 - t.window_negative as i64,
                    positive: t.window_positive,
                    specific_flow: flow.map(|j| j / length),
                    time_gap_mean: t.gaps.mean(),
                    time_gap_sd: t.gaps.sample_sd(),
                    total,
                }
            })
            .collect();
        let areas = self
            .spec
            .areas
            .iter()
            .zip(&self.areas)
            .zip(&self.sizes)
            .map(|((a, t), &size)| {
                let frames = (t.frames > 0).then_some(t.frames as f64);
                AreaReport {
                    area: size,
                    frames: t.frames,
                    mean_count: frames.map(|n| t.sum_count / n),
                    mean_density: frames.map(|n| t.sum_density / n),
                    mean_speed: (t.speed_frames > 0).then(|| t.sum_speed / t.speed_frames as f64),
                    mean_voronoi_density: (t.voronoi_frames > 0)
                        .then(|| t.sum_voronoi_density / t.voronoi_frames as f64),
                    mean_voronoi_speed: (t.voronoi_frames > 0)
                        .then(|| t.sum_voronoi_speed / t.voronoi_frames as f64),
                    name: a.name.clone(),
                }
            })
            .collect();
        MeasurementReport {
            areas,
            left: self.left,
            lines,
        }
    }

    /// The summary as lines of text for the end of a run: one per line and area, and one for
    /// the exits when the world has any (evacuation time, or agents still inside).
    #[must_use]
    pub fn summary(&self) -> Vec<String> {
        let r = self.report();
        let opt = |v: Option<f64>, digits: usize| {
            v.map_or_else(|| "-".to_string(), |v| format!("{v:.digits$}"))
        };
        let mut out = Vec::new();
        for l in &r.lines {
            out.push(format!(
                "line {}: {} crossings (+{} / -{}, net {}) | first {} s, last {} s | J {} 1/s | N-t: {} agents, J {} 1/s | J/b {} 1/(m s) | time gap mean {} s, sd {} s",
                l.name,
                l.total,
                l.positive,
                l.negative,
                l.net,
                opt(l.first_time, 3),
                opt(l.last_time, 3),
                opt(l.flow, 3),
                l.nt_count,
                opt(l.nt_flow, 3),
                opt(l.specific_flow, 3),
                opt(l.time_gap_mean, 3),
                opt(l.time_gap_sd, 3),
            ));
        }
        for a in &r.areas {
            out.push(format!(
                "area {}: {:.3} m^2 | {} frames | mean count {} | mean density {} 1/m^2 | mean speed {} m/s{}",
                a.name,
                a.area,
                a.frames,
                opt(a.mean_count, 2),
                opt(a.mean_density, 3),
                opt(a.mean_speed, 3),
                if self.spec.voronoi {
                    format!(
                        " | Voronoi density {} 1/m^2, speed {} m/s",
                        opt(a.mean_voronoi_density, 3),
                        opt(a.mean_voronoi_speed, 3)
                    )
                } else {
                    String::new()
                },
            ));
        }
        if let Some([t0, t1]) = self.spec.window {
            out.push(format!("measurement window: {t0} s to {t1} s"));
        }
        if self.has_exits {
            out.push(match self.evacuation_time() {
                Some(t) => format!(
                    "evacuation: the last agent left at {t:.3} s | {} left, none inside",
                    self.left
                ),
                None => format!(
                    "evacuation: not emptied | {} left, {} still inside",
                    self.left, self.inside
                ),
            });
        }
        out
    }
}
