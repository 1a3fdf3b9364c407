//! The journey system's state and its per-step update.
//!
//! [`Journeys`] holds the world's stages (with their queues' and waiting sets' occupants), its
//! journeys (with their round robins' counters), each agent's journey and stage by id, and the
//! routes. [`Journeys::before_step`] runs at the start of a step: it seats arriving agents in
//! queues and waiting sets, completes stages and applies transitions, then writes every
//! journey agent's own target point. [`Journeys::leaves`] tells the exit pass at the end of a
//! step which agents leave through their exit stage.
//!
//! Invariant: everything here is keyed by [`AgentId`] and visited in ascending id order, so the
//! results do not depend on the agents' storage order.

use glam::Vec2;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::routes::Routes;
use super::{Journey, JourneyId, Stage, StageId, Transition};
use crate::agents::{AgentId, Agents};
use crate::error::{Error, Result};
use crate::geometry::Walkable;
use crate::obstacles::Obstacles;

/// No journey or no stage.
const NONE: u32 = u32::MAX;

/// How far ahead along its route an agent's target lies, m (beyond any slowing radius).
const LOOKAHEAD: f32 = 2.0;

/// How near a queue's or waiting set's slot an agent in sight of it walks straight to it, m.
const SIGHT: f32 = 10.0;

/// How close to a free slot an agent must be to take it, m.
const SEAT_REACH: f32 = 2.0;

/// How close to a deactivated waiting set's first slot an agent completes it, m.
const RELEASE_REACH: f32 = 1.0;

/// The agents of one parallel task of the per-agent passes.
const CHUNK: usize = 1024;

/// The state of one stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct StageState {
    stage: Stage,
    /// A queue's or waiting set's agents, in slot order.
    occupants: Vec<AgentId>,
    /// A queue's agents popped and not yet moved on.
    released: Vec<AgentId>,
    /// Agents that left the world through this (exit) stage.
    left: u64,
}

/// The state of one journey: the journey and, per transition, its round robin's counter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct JourneyState {
    journey: Journey,
    counters: Vec<u64>,
}

/// A queue's state, as [`World::queue`](crate::World::queue) reports it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QueueState {
    /// The agents in the queue's (or waiting set's) slots, the front first.
    pub occupants: Vec<AgentId>,
    /// Agents popped from a queue that move on at the next step.
    pub released: Vec<AgentId>,
    /// For a waiting set, whether it holds its agents (always true for a queue).
    pub active: bool,
}

/// Per stage, how many live agents target it and how many left the world through it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StageCounts {
    /// Live agents whose current stage it is.
    pub targeting: usize,
    /// Agents that left the world through it (exit stages).
    pub left: u64,
}

/// The journey system (see the module documentation).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub(crate) struct Journeys {
    stages: Vec<StageState>,
    journeys: Vec<JourneyState>,
    /// Per agent id: its journey and stage (`NONE` for none).
    agent: Vec<(u32, u32)>,
    /// Per agent id: its direct steering target (NaN for none: it stays where it is).
    direct: Vec<Vec2>,
    /// Agents driven from outside: id, position and velocity, ascending by id.
    #[serde(default)]
    external: Vec<(AgentId, Vec2, Vec2)>,
    /// Routing over the walkable area, when the world has one (rebuilt on load).
    #[serde(skip)]
    routes: Option<Routes>,
    /// Whether `routes` must be built before the next step.
    #[serde(skip)]
    routes_stale: bool,
    /// Per stage, the ids of the live agents on it (ascending), rebuilt every step.
    #[serde(skip)]
    on_stage: Vec<Vec<u32>>,
    /// Per agent id, its slot in its queue or waiting set (`NONE` for none), every step.
    #[serde(skip)]
    slot_of: Vec<u32>,
    /// Per stage, the live agents targeting it while transitions are applied, every step.
    #[serde(skip)]
    targeting: Vec<usize>,
    /// Per agent (storage order), whether it completed its stage this step.
    #[serde(skip)]
    done: Vec<bool>,
    /// The ids of the agents that completed their stage this step, ascending.
    #[serde(skip)]
    movers: Vec<u32>,
}

impl Journeys {
    /// Whether the world has neither stages nor agents driven from outside.
    pub(crate) fn is_empty(&self) -> bool {
        self.stages.is_empty() && self.external.is_empty()
    }

    /// Records agent `id`'s position and velocity as written from outside.
    pub(crate) fn set_external(&mut self, id: AgentId, position: Vec2, velocity: Vec2) {
        match self.external.binary_search_by_key(&id, |e| e.0) {
            Ok(k) => self.external[k] = (id, position, velocity),
            Err(k) => self.external.insert(k, (id, position, velocity)),
        }
    }

    /// Whether agent `id` is driven from outside.
    pub(crate) fn is_external(&self, id: AgentId) -> bool {
        self.external.binary_search_by_key(&id, |e| e.0).is_ok()
    }

    /// At the end of a step: every live agent driven from outside is where it was put, with
    /// the velocity it was given (whatever the step did to it); the departed are forgotten.
    pub(crate) fn hold_external(&mut self, agents: &mut Agents) {
        self.external
            .retain(|&(id, p, v)| match agents.index_of(id) {
                Some(i) => {
                    agents.pos_x[i] = p.x;
                    agents.pos_y[i] = p.y;
                    agents.vel_x[i] = v.x;
                    agents.vel_y[i] = v.y;
                    true
                }
                None => false,
            });
    }

    /// Routes built on `area` for the current stages, for a switch of the walkable area.
    ///
    /// Stages the new area cuts off get no route.
    ///
    /// # Errors
    /// As [`Routes::new`], for a raster too large.
    pub(crate) fn routes_on(&self, area: &Walkable) -> Result<Option<Routes>> {
        if self.stages.is_empty() {
            return Ok(None);
        }
        let stages: Vec<Stage> = self.stages.iter().map(|s| s.stage.clone()).collect();
        Routes::new_cut(area, &stages).map(Some)
    }

    /// Installs routes built by [`Journeys::routes_on`].
    pub(crate) fn set_routes(&mut self, routes: Option<Routes>) {
        self.routes = routes;
        self.routes_stale = false;
    }

    /// The stages.
    pub(crate) fn stage_count(&self) -> usize {
        self.stages.len()
    }

    /// Stage `s`.
    pub(crate) fn stage(&self, s: StageId) -> Result<&Stage> {
        self.stages
            .get(s.0 as usize)
            .map(|st| &st.stage)
            .ok_or(Error::UnknownStage {
                stage: s.0,
                count: self.stages.len(),
            })
    }

    /// Journey `j`.
    pub(crate) fn journey(&self, j: JourneyId) -> Result<&Journey> {
        self.journeys
            .get(j.0 as usize)
            .map(|js| &js.journey)
            .ok_or(Error::UnknownJourney {
                journey: j.0,
                count: self.journeys.len(),
            })
    }

    /// Adds a stage after checking it against the walkable area.
    pub(crate) fn add_stage(&mut self, stage: Stage, area: Option<&Walkable>) -> Result<StageId> {
        let k = self.stages.len();
        if k >= NONE as usize {
            return Err(Error::Invalid {
                name: "stage".into(),
                reason: "a world has at most 2^32 - 1 stages".into(),
            });
        }
        stage.validate(&format!("stage {k}"), area)?;
        if let Some(r) = &mut self.routes {
            // `add` fails before it changes anything; `build` cannot fail on checked goals.
            r.add(k, &stage)?;
            r.build()?;
        } else if let Some(a) = area {
            // Checked now, so that a stage no cell reaches fails where it is added.
            let mut all: Vec<Stage> = self.stages.iter().map(|s| s.stage.clone()).collect();
            all.push(stage.clone());
            self.routes = Some(Routes::new(a, &all)?);
            self.routes_stale = false;
        }
        self.stages.push(StageState {
            stage,
            occupants: Vec::new(),
            released: Vec::new(),
            left: 0,
        });
        Ok(StageId(k as u32))
    }

    /// Adds a journey after checking it.
    pub(crate) fn add_journey(&mut self, journey: Journey) -> Result<JourneyId> {
        let k = self.journeys.len();
        if k >= NONE as usize {
            return Err(Error::Invalid {
                name: "journey".into(),
                reason: "a world has at most 2^32 - 1 journeys".into(),
            });
        }
        let stages: Vec<Stage> = self.stages.iter().map(|s| s.stage.clone()).collect();
        journey.validate(&format!("journey {k}"), &stages)?;
        if let Some(r) = self.current_routes() {
            for (from, t) in &journey.transitions {
                let targets = t.targets();
                let Some(to) = targets
                    .iter()
                    .find(|to| !r.stage_reaches(&stages[from.0 as usize], to.0 as usize))
                else {
                    continue;
                };
                return Err(Error::Invalid {
                    name: format!("journey {k}"),
                    reason: format!(
                        "stage {} cannot be reached from stage {}: no path of free cells of the \
                         walkable area (cells of {} m) joins them",
                        to.0,
                        from.0,
                        super::routes::CELL_SIZE
                    ),
                });
            }
        }
        let counters = vec![0; journey.transitions.len()];
        self.journeys.push(JourneyState { journey, counters });
        Ok(JourneyId(k as u32))
    }

    /// The routes, when they are built for the current walkable area.
    fn current_routes(&self) -> Option<&Routes> {
        self.routes.as_ref().filter(|_| !self.routes_stale)
    }

    /// Puts agent `id` (of `issued` ids), standing at `at`, on journey `j` at stage `s` (the
    /// journey's first when `None`).
    pub(crate) fn assign(
        &mut self,
        id: AgentId,
        issued: usize,
        at: Vec2,
        j: JourneyId,
        s: Option<StageId>,
    ) -> Result<()> {
        let journey = self.journey(j)?;
        let s = s.unwrap_or(journey.stages[0]);
        self.stage(s)?;
        if !journey.stages.contains(&s) {
            return Err(Error::Invalid {
                name: format!("journey {}", j.0),
                reason: format!("stage {} is not one of its stages", s.0),
            });
        }
        if let Some(r) = self.current_routes()
            && !r.reaches(s.0 as usize, at)
        {
            return Err(Error::Invalid {
                name: format!("agent {id}"),
                reason: format!(
                    "at ({}, {}) it cannot reach stage {}: no path of free cells of the \
                     walkable area (cells of {} m) leads there",
                    at.x,
                    at.y,
                    s.0,
                    super::routes::CELL_SIZE
                ),
            });
        }
        if self.agent.len() < issued {
            self.agent.resize(issued, (NONE, NONE));
        }
        self.leave_slots(id);
        self.agent[id.0 as usize] = (j.0, s.0);
        Ok(())
    }

    /// The live agents on a journey whose current stage cannot be reached from where they
    /// stand, ascending by id: a stage with a place that the walkable area cuts off, or one
    /// that no path of free cells joins to the agent's cell (as [`Journeys::assign`] judges
    /// it). None without a walkable area or before the routes are built.
    pub(crate) fn stranded(&self, agents: &Agents) -> Vec<AgentId> {
        let Some(r) = self.current_routes() else {
            return Vec::new();
        };
        let mut out: Vec<AgentId> = (0..agents.len())
            .filter_map(|i| {
                let id = agents.id(i);
                let (_, s) = self.of(id)?;
                let k = s.0 as usize;
                let cut = !matches!(self.stages[k].stage, Stage::DirectSteering) && !r.has_route(k);
                (cut || !r.reaches(k, agents.position(i))).then_some(id)
            })
            .collect();
        out.sort_unstable();
        out
    }

    /// Agent `id`'s journey and stage, if it is on one.
    pub(crate) fn of(&self, id: AgentId) -> Option<(JourneyId, StageId)> {
        match self.agent.get(id.0 as usize) {
            Some(&(j, s)) if j != NONE => Some((JourneyId(j), StageId(s))),
            _ => None,
        }
    }

    /// Takes agent `id` out of every queue and waiting set (it changed journey or stage).
    fn leave_slots(&mut self, id: AgentId) {
        if let Some((_, s)) = self.of(id)
            && let Some(st) = self.stages.get_mut(s.0 as usize)
        {
            st.occupants.retain(|&o| o != id);
            st.released.retain(|&o| o != id);
        }
    }

    /// Sets agent `id`'s direct steering target.
    pub(crate) fn set_direct(&mut self, id: AgentId, issued: usize, target: Vec2) {
        if self.direct.len() < issued {
            self.direct.resize(issued, Vec2::NAN);
        }
        self.direct[id.0 as usize] = target;
    }

    /// Releases the first `n` agents of queue `s`.
    pub(crate) fn pop(&mut self, s: StageId, n: usize) -> Result<()> {
        self.stage(s)?;
        let st = &mut self.stages[s.0 as usize];
        if !matches!(st.stage, Stage::Queue { .. }) {
            return Err(Error::Invalid {
                name: format!("stage {}", s.0),
                reason: format!(
                    "only a queue can be popped, and it is a {}",
                    st.stage.kind()
                ),
            });
        }
        if n > st.occupants.len() {
            return Err(Error::Invalid {
                name: format!("stage {}", s.0),
                reason: format!(
                    "the queue holds {} agents in its slots; cannot pop {n}",
                    st.occupants.len()
                ),
            });
        }
        let popped: Vec<AgentId> = st.occupants.drain(..n).collect();
        st.released.extend(popped);
        Ok(())
    }

    /// Activates or deactivates waiting set `s` (activating empties its slots).
    pub(crate) fn set_active(&mut self, s: StageId, active: bool) -> Result<()> {
        self.stage(s)?;
        let st = &mut self.stages[s.0 as usize];
        match &mut st.stage {
            Stage::WaitingSet { active: a, .. } => {
                if active && !*a {
                    st.occupants.clear();
                }
                *a = active;
                Ok(())
            }
            other => Err(Error::Invalid {
                name: format!("stage {}", s.0),
                reason: format!(
                    "only a waiting set can be activated, and it is a {}",
                    other.kind()
                ),
            }),
        }
    }

    /// Queue or waiting set `s`'s state.
    pub(crate) fn queue(&self, s: StageId) -> Result<QueueState> {
        let st = &self.stages.get(s.0 as usize).ok_or(Error::UnknownStage {
            stage: s.0,
            count: self.stages.len(),
        })?;
        match st.stage {
            Stage::Queue { .. } | Stage::WaitingSet { .. } => Ok(QueueState {
                occupants: st.occupants.clone(),
                released: st.released.clone(),
                active: !matches!(st.stage, Stage::WaitingSet { active: false, .. }),
            }),
            _ => Err(Error::Invalid {
                name: format!("stage {}", s.0),
                reason: format!("it is a {}, not a queue or waiting set", st.stage.kind()),
            }),
        }
    }

    /// Per stage, the live agents targeting it and those that left through it.
    pub(crate) fn counts(&self, agents: &Agents) -> Vec<StageCounts> {
        let mut c: Vec<StageCounts> = self
            .stages
            .iter()
            .map(|st| StageCounts {
                targeting: 0,
                left: st.left,
            })
            .collect();
        for &id in agents.ids() {
            if let Some((_, s)) = self.of(id) {
                c[s.0 as usize].targeting += 1;
            }
        }
        c
    }

    /// Marks the routes for a rebuild on `area` (the walkable area changed).
    pub(crate) fn geometry_changed(&mut self) {
        self.routes = None;
        self.routes_stale = true;
    }

    /// Builds the routes on `area` when they are missing (a loaded world, a changed area).
    ///
    /// # Errors
    /// As [`Routes::new`]: a stage no free cell of the new area reaches.
    pub(crate) fn ensure_routes(&mut self, area: Option<&Walkable>) -> Result<()> {
        if self.stages.is_empty() || (self.routes.is_some() && !self.routes_stale) {
            return Ok(());
        }
        self.routes = match area {
            Some(a) => {
                let stages: Vec<Stage> = self.stages.iter().map(|s| s.stage.clone()).collect();
                Some(Routes::new_cut(a, &stages)?)
            }
            None => None,
        };
        self.routes_stale = false;
        Ok(())
    }

    /// The start of a step: seats arriving agents, completes stages, applies transitions, and
    /// writes every journey agent's own target point. With `parallel`, the per-agent tests and
    /// targets run in tasks of [`CHUNK`] agents on the current pool (each agent's result
    /// depends on itself alone, so the bits do not depend on the thread count).
    pub(crate) fn before_step(
        &mut self,
        agents: &mut Agents,
        obstacles: &Obstacles,
        parallel: bool,
    ) {
        if self.stages.is_empty() {
            return;
        }
        let issued = agents.ids_issued();
        if self.agent.len() < issued {
            self.agent.resize(issued, (NONE, NONE));
        }
        // The live agents on each stage, by ascending id; forget the departed.
        self.on_stage.resize_with(self.stages.len(), Vec::new);
        for l in &mut self.on_stage {
            l.clear();
        }
        for (id, entry) in self.agent.iter_mut().enumerate() {
            if entry.0 == NONE {
                continue;
            }
            if agents.contains(AgentId(id as u32)) {
                self.on_stage[entry.1 as usize].push(id as u32);
            } else {
                *entry = (NONE, NONE);
            }
        }
        for st in &mut self.stages {
            st.occupants.retain(|&id| agents.contains(id));
            st.released.retain(|&id| agents.contains(id));
        }
        self.seat(agents, obstacles);
        self.complete(agents, parallel);
        self.write_targets(agents, obstacles, parallel);
    }

    /// Queues and active waiting sets take, slot by slot from the first free one, the nearest
    /// agent on the stage within reach and in sight of the slot (the lower id on a tie); they
    /// stop at the first slot nobody takes.
    fn seat(&mut self, agents: &Agents, obstacles: &Obstacles) {
        for (k, st) in self.stages.iter_mut().enumerate() {
            let slots = match &st.stage {
                Stage::Queue { slots }
                | Stage::WaitingSet {
                    slots,
                    active: true,
                } => slots,
                _ => continue,
            };
            while st.occupants.len() < slots.len() {
                let slot = slots[st.occupants.len()];
                let mut best: Option<(AgentId, f32)> = None;
                for &raw in &self.on_stage[k] {
                    let id = AgentId(raw);
                    let Some(i) = agents.index_of(id) else {
                        continue;
                    };
                    let p = agents.position(i);
                    let d = p.distance(slot);
                    if d > SEAT_REACH || best.is_some_and(|(_, b)| d >= b) {
                        continue;
                    }
                    if st.occupants.contains(&id) || st.released.contains(&id) {
                        continue;
                    }
                    if obstacles.crosses_wall(slot, p) {
                        continue;
                    }
                    best = Some((id, d));
                }
                match best {
                    Some((id, _)) => st.occupants.push(id),
                    None => break,
                }
            }
        }
    }

    /// Whether agent `id` at `p`, on stage `s`, completed it.
    fn completed(&self, id: AgentId, s: u32, p: Vec2) -> bool {
        let st = &self.stages[s as usize];
        match &st.stage {
            Stage::Waypoint { position, distance } => p.distance(*position) <= *distance,
            Stage::Queue { .. } => st.released.contains(&id),
            Stage::WaitingSet {
                slots,
                active: false,
            } => st.occupants.contains(&id) || p.distance(slots[0]) <= RELEASE_REACH,
            _ => false,
        }
    }

    /// Every agent that completed its stage moves on by its transition, in ascending id order.
    ///
    /// Whether an agent completed its stage depends on its position and on the stage's slots
    /// as they were before anyone moved on (moving on takes only the agent itself out of
    /// them), so the tests run first, per agent (in parallel with `parallel`); the transitions
    /// then run for the agents that completed, by ascending id.
    fn complete(&mut self, agents: &Agents, parallel: bool) {
        let mut done = std::mem::take(&mut self.done);
        done.clear();
        done.resize(agents.len(), false);
        let this = &*self;
        let test = |base: usize, out: &mut [bool]| {
            for (k, d) in out.iter_mut().enumerate() {
                let i = base + k;
                let id = agents.id(i);
                *d = match this.agent.get(id.0 as usize) {
                    Some(&(j, s)) if j != NONE => this.completed(id, s, agents.position(i)),
                    _ => false,
                };
            }
        };
        if parallel {
            done.par_chunks_mut(CHUNK)
                .enumerate()
                .for_each(|(c, out)| test(c * CHUNK, out));
        } else {
            test(0, &mut done);
        }
        let mut movers = std::mem::take(&mut self.movers);
        movers.clear();
        // One reservation for the run: at most every agent moves on.
        movers.reserve(agents.len());
        movers.extend(
            done.iter()
                .enumerate()
                .filter(|&(_, &d)| d)
                .map(|(i, _)| agents.id(i).0),
        );
        movers.sort_unstable();
        let mut targeting = std::mem::take(&mut self.targeting);
        targeting.clear();
        targeting.extend(self.on_stage.iter().map(Vec::len));
        for &raw in &movers {
            let raw = raw as usize;
            let (j, s) = self.agent[raw];
            let id = AgentId(raw as u32);
            let js = &mut self.journeys[j as usize];
            let Some(t) = js.journey.transitions.iter().position(|(f, _)| f.0 == s) else {
                continue;
            };
            let next = match &js.journey.transitions[t].1 {
                Transition::Fixed { next } => *next,
                Transition::RoundRobin { weighted } => {
                    let sum: u64 = weighted.iter().map(|w| u64::from(w.1)).sum();
                    let at = js.counters[t] % sum;
                    js.counters[t] = js.counters[t].wrapping_add(1);
                    let mut acc = 0u64;
                    let mut pick = weighted[0].0;
                    for &(stage, w) in weighted {
                        acc += u64::from(w);
                        if at < acc {
                            pick = stage;
                            break;
                        }
                    }
                    pick
                }
                Transition::LeastTargeted { candidates } => {
                    let mut pick = candidates[0];
                    for &c in candidates {
                        if targeting[c.0 as usize] < targeting[pick.0 as usize] {
                            pick = c;
                        }
                    }
                    pick
                }
            };
            let st = &mut self.stages[s as usize];
            st.occupants.retain(|&o| o != id);
            st.released.retain(|&o| o != id);
            targeting[s as usize] -= 1;
            targeting[next.0 as usize] += 1;
            self.agent[raw].1 = next.0;
        }
        self.targeting = targeting;
        self.done = done;
        self.movers = movers;
    }

    /// Writes each journey agent's own target: down its stage's route, or at the stage's point
    /// (a slot within [`SIGHT`] in sight, a direct steering target, or on a goal cell); in
    /// parallel tasks with `parallel`.
    fn write_targets(&mut self, agents: &mut Agents, obstacles: &Obstacles, parallel: bool) {
        self.slot_of.clear();
        self.slot_of.resize(self.agent.len(), NONE);
        for st in &self.stages {
            for (k, id) in st.occupants.iter().enumerate() {
                self.slot_of[id.0 as usize] = k as u32;
            }
        }
        let this = &*self;
        let n = agents.len();
        let (ids, px, py) = (&agents.ids[..], &agents.pos_x[..], &agents.pos_y[..]);
        let write = |base: usize, tx: &mut [f32], ty: &mut [f32]| {
            for (k, (tx, ty)) in tx.iter_mut().zip(ty.iter_mut()).enumerate() {
                let i = base + k;
                if let Some(t) = this.target(ids[i], Vec2::new(px[i], py[i]), obstacles) {
                    // Within the coordinate ceiling: positions and stage points are, and so
                    // is a step of two metres from a position.
                    (*tx, *ty) = (t.x, t.y);
                }
            }
        };
        let (tx, ty) = (&mut agents.target_x[..n], &mut agents.target_y[..n]);
        if parallel {
            tx.par_chunks_mut(CHUNK)
                .zip(ty.par_chunks_mut(CHUNK))
                .enumerate()
                .for_each(|(c, (x, y))| write(c * CHUNK, x, y));
        } else {
            write(0, tx, ty);
        }
    }

    /// The target of agent `id` standing at `p`, when it is on a journey.
    #[inline]
    fn target(&self, id: AgentId, p: Vec2, obstacles: &Obstacles) -> Option<Vec2> {
        let &(j, s) = self.agent.get(id.0 as usize)?;
        if j == NONE {
            return None;
        }
        let k = s as usize;
        let st = &self.stages[k];
        let (point, through) = match &st.stage {
            Stage::Waypoint { position, .. } => (*position, true),
            Stage::Exit { area } => (
                self.routes
                    .as_ref()
                    .and_then(|r| r.centre(k))
                    .unwrap_or((area.min() + area.max()) * 0.5),
                true,
            ),
            Stage::Queue { slots }
            | Stage::WaitingSet {
                slots,
                active: true,
            } => {
                let slot = match self.slot_of[id.0 as usize] {
                    NONE => st.occupants.len().min(slots.len() - 1),
                    n => n as usize,
                };
                (slots[slot], false)
            }
            Stage::WaitingSet { slots, .. } => (slots[0], true),
            Stage::DirectSteering => {
                let d = self.direct.get(id.0 as usize).copied().unwrap_or(Vec2::NAN);
                (if d.is_finite() { d } else { p }, false)
            }
        };
        let routed = self
            .routes
            .as_ref()
            .map_or(Vec2::ZERO, |r| r.direction(k, p));
        // A point target in sight and near goes straight (a queue's slot along the queue).
        let direct = !through
            && (matches!(st.stage, Stage::DirectSteering)
                || (p.distance_squared(point) <= SIGHT * SIGHT
                    && !obstacles.crosses_wall(p, point)));
        Some(if routed != Vec2::ZERO && !direct {
            p + routed * LOOKAHEAD
        } else if through {
            let d = point - p;
            let len = d.length();
            if len > 0.0 {
                p + d * (len.max(LOOKAHEAD) / len)
            } else {
                point
            }
        } else {
            point
        })
    }

    /// Whether agent `id` at `p` leaves through its exit stage (and counts it there).
    pub(crate) fn leaves(&mut self, id: AgentId, p: Vec2) -> bool {
        let Some(&(j, s)) = self.agent.get(id.0 as usize) else {
            return false;
        };
        if j == NONE {
            return false;
        }
        let st = &mut self.stages[s as usize];
        if let Stage::Exit { area } = &st.stage
            && area.contains(p)
        {
            st.left += 1;
            self.agent[id.0 as usize] = (NONE, NONE);
            return true;
        }
        false
    }

    /// The same state checked part by part as the API checks it (a checkpoint's): stages and
    /// journeys added again (which builds the routes on `area`), then the counters, the
    /// agents' journeys and stages, the slots' occupants and the direct targets against
    /// `issued` ids.
    pub(crate) fn restored(self, area: Option<&Walkable>, issued: usize) -> Result<Journeys> {
        let bad = |what: String| Error::Invalid {
            name: "journeys".into(),
            reason: what,
        };
        let mut fresh = Journeys::default();
        // Checked without the area: a stage that a later switch of the area cut off is kept.
        for st in &self.stages {
            fresh.add_stage(st.stage.clone(), None)?;
        }
        fresh.routes_stale = true;
        fresh.ensure_routes(area)?;
        for (k, js) in self.journeys.into_iter().enumerate() {
            if js.counters.len() != js.journey.transitions.len() {
                return Err(bad(format!(
                    "journey {k} has {} counters for {} transitions",
                    js.counters.len(),
                    js.journey.transitions.len()
                )));
            }
            fresh.add_journey(js.journey)?;
            fresh.journeys[k].counters = js.counters;
        }
        if self.agent.len() > issued || self.direct.len() > issued {
            return Err(bad(format!(
                "more agent entries than the {issued} ids issued"
            )));
        }
        for (id, &(j, s)) in self.agent.iter().enumerate() {
            if (j, s) == (NONE, NONE) {
                continue;
            }
            let ok = fresh
                .journeys
                .get(j as usize)
                .is_some_and(|js| js.journey.stages.contains(&StageId(s)));
            if !ok {
                return Err(bad(format!(
                    "agent #{id} is on journey {j} at stage {s}, which is not one of its stages"
                )));
            }
        }
        for (id, &d) in self.direct.iter().enumerate() {
            if !d.is_nan() {
                crate::error::coordinate("direct target", d)
                    .map_err(|e| bad(format!("agent #{id}: {e}")))?;
            }
        }
        for (k, st) in self.stages.into_iter().enumerate() {
            let slots = match &st.stage {
                Stage::Queue { slots } | Stage::WaitingSet { slots, .. } => slots.len(),
                _ => 0,
            };
            let mut seen: Vec<AgentId> = st.occupants.iter().chain(&st.released).copied().collect();
            seen.sort_unstable();
            let twice = seen.windows(2).any(|w| w[0] == w[1]);
            if st.occupants.len() > slots
                || (slots == 0 && !st.released.is_empty())
                || seen.iter().any(|id| id.0 as usize >= issued)
                || twice
            {
                return Err(bad(format!(
                    "stage {k}'s slots hold agents it cannot: {} in {slots} slots, {} released",
                    st.occupants.len(),
                    st.released.len()
                )));
            }
            let f = &mut fresh.stages[k];
            f.occupants = st.occupants;
            f.released = st.released;
            f.left = st.left;
        }
        for (k, &(id, p, v)) in self.external.iter().enumerate() {
            if id.0 as usize >= issued || (k > 0 && self.external[k - 1].0 >= id) {
                return Err(bad(format!(
                    "external agent #{id} was never added or is out of order"
                )));
            }
            crate::error::coordinate("external position", p)
                .and_then(|_| crate::error::finite_vec("external velocity", v))
                .map_err(|e| bad(format!("external agent #{id}: {e}")))?;
        }
        fresh.agent = self.agent;
        fresh.direct = self.direct;
        fresh.external = self.external;
        Ok(fresh)
    }

    /// The routing grid's cell count (for the docs' measurements and tests).
    pub(crate) fn route_cells(&self) -> usize {
        self.routes.as_ref().map_or(0, |r| {
            r.grid().width() as usize * r.grid().height() as usize
        })
    }
}
