//! The simulation thread of `throng serve`: steps the world, applies the page's controls through
//! the library's validated API, and publishes frames, the state and the geometry.
//!
//! Invariants: only this thread touches the world. Publishing never blocks: each client's queue
//! holds one frame, and a frame that finds the queue full is dropped for that client. A control
//! is applied between two steps and answered with the state after it, so a reply to `pause`
//! names the frame the world stays at.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use throng::gravity::GravityPoint;
use throng::obstacles::{Circle, Wall};
use throng::prelude::Vec2;
use throng::scenario::Scenario;
use throng::world::PhaseTimes;
use throng::{OccupancyGrid, World};

use super::frame::{self, FrameInfo};
use crate::WorldArgs;

/// The most steps one `step` control or one frame may run.
pub const MAX_STEPS: u64 = 1000;
/// How far (in cells) a goal click looks for a free cell around a wall cell.
const GOAL_SNAP_CELLS: i64 = 8;

/// An encoded frame, shared by every client's queue.
pub type Frame = Arc<Vec<u8>>;
/// A control and where its answer goes: the state JSON, or an error message.
pub type Request = (Control, Sender<Result<String, String>>);

/// What the server threads and the simulation thread share.
#[derive(Debug, Default)]
pub struct Shared {
    /// Each streaming client's queue (capacity 1).
    pub clients: Mutex<Vec<SyncSender<Frame>>>,
    /// The newest frame, sent first to a client that connects.
    pub latest: Mutex<Option<Frame>>,
    /// The newest `GET /state` body.
    pub state: Mutex<Arc<String>>,
    /// The newest `GET /world` body.
    pub world: Mutex<Arc<String>>,
    /// Set by Ctrl-C: every loop ends.
    pub stop: AtomicBool,
}

/// Locks a mutex, taking the data of a poisoned one (its holders only replace whole values).
pub fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Runs the simulation thread's `body`. When it panics, no step or control runs any more, so
/// `GET /state` says so from then on: its `error` names the panic and `paused` is true (the
/// page shows the error; controls get 503 as the thread has gone).
pub fn guarded(shared: &Shared, body: impl FnOnce()) {
    let Err(panic) = std::panic::catch_unwind(std::panic::AssertUnwindSafe(body)) else {
        return;
    };
    let why = panic
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".into());
    let mut state = lock(&shared.state);
    let mut v: Value = serde_json::from_str(&state).unwrap_or(Value::Null);
    if !v.is_object() {
        v = json!({});
    }
    v["error"] = json!(format!(
        "the simulation stopped ({}); restart throng serve",
        why.escape_debug()
    ));
    v["paused"] = json!(true);
    *state = Arc::new(v.to_string());
}

/// A control from the page (`POST /control`), parsed and range-checked; the world's own checks
/// run when it is applied.
#[derive(Clone, Debug, PartialEq)]
pub enum Control {
    /// Stop stepping.
    Pause,
    /// Go on stepping.
    Play,
    /// Pause and run this many steps.
    Step(u64),
    /// Steps between frames.
    StepsPerFrame(u64),
    /// Pace frames to the wall clock (`dt` seconds a step) or run as fast as possible.
    Realtime(bool),
    /// Rebuild the world from the scenario, with another seed or agent count.
    Reset {
        /// New seed.
        seed: Option<u64>,
        /// New agent count.
        agents: Option<usize>,
    },
    /// Move one channel's goals of a field to the cell at a point.
    Goal {
        /// Field number.
        field: usize,
        /// Channel number.
        channel: usize,
        /// The point, world units.
        at: Vec2,
    },
    /// Re-randomise every channel's goals of a field.
    ShuffleGoals {
        /// Field number.
        field: usize,
    },
    /// Add a static gravity point (positive strength repels).
    Gravity {
        /// The point.
        at: Vec2,
        /// Force at distance 1.
        strength: f32,
        /// Cut-off radius (default: a tenth of the world's longer side, or 20).
        radius: Option<f32>,
        /// Distance exponent (default 2).
        exponent: Option<f32>,
    },
    /// Add a wall segment.
    Wall {
        /// One end.
        a: Vec2,
        /// The other end.
        b: Vec2,
    },
    /// Add a circular obstacle.
    Circle {
        /// Centre.
        at: Vec2,
        /// Radius.
        radius: f32,
    },
}

/// A required number of a control.
fn number(v: &Value, key: &str) -> Result<f64, String> {
    match v.get(key) {
        Some(x) => x
            .as_f64()
            .ok_or_else(|| format!("`{key}` must be a number, not {x}")),
        None => Err(format!("`{key}` is missing")),
    }
}

/// An optional number of a control.
fn opt_number(v: &Value, key: &str) -> Result<Option<f64>, String> {
    match v.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(_) => number(v, key).map(Some),
    }
}

/// An optional whole number of a control, at most `max`.
fn opt_count(v: &Value, key: &str, max: u64) -> Result<Option<u64>, String> {
    match v.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(x) => match x.as_u64() {
            Some(n) if n <= max => Ok(Some(n)),
            _ => Err(format!(
                "`{key}` must be a whole number from 0 to {max}, not {x}"
            )),
        },
    }
}

/// A point of two required numbers (`f32`; out-of-range values become infinite and are
/// rejected by the world's checks).
fn point(v: &Value, x: &str, y: &str) -> Result<Vec2, String> {
    Ok(Vec2::new(number(v, x)? as f32, number(v, y)? as f32))
}

impl Control {
    /// Parses a control's JSON body: `{"cmd": "pause"}`, `{"cmd": "goal", "x": 10, "y": 20}`, ...
    ///
    /// # Errors
    /// A message naming what is wrong: not JSON, no `cmd`, an unknown command, a missing or
    /// badly typed value.
    pub fn parse(body: &[u8]) -> Result<Control, String> {
        let v: Value =
            serde_json::from_slice(body).map_err(|e| format!("the body is not JSON: {e}"))?;
        let Some(cmd) = v.get("cmd").and_then(Value::as_str) else {
            return Err("expected a JSON object with a string `cmd`".into());
        };
        let steps = |key| -> Result<u64, String> {
            match opt_count(&v, key, MAX_STEPS)? {
                Some(0) => Err(format!("`{key}` must be at least 1")),
                Some(n) => Ok(n),
                None => Ok(1),
            }
        };
        let index = |key| -> Result<usize, String> {
            Ok(opt_count(&v, key, u64::from(u32::MAX))?.unwrap_or(0) as usize)
        };
        Ok(match cmd {
            "pause" => Control::Pause,
            "play" => Control::Play,
            "step" => Control::Step(steps("n")?),
            "steps_per_frame" => {
                number(&v, "n")?;
                Control::StepsPerFrame(steps("n")?)
            }
            "realtime" => match v.get("on").and_then(Value::as_bool) {
                Some(on) => Control::Realtime(on),
                None => return Err("`on` must be true or false".into()),
            },
            "reset" => Control::Reset {
                seed: opt_count(&v, "seed", u64::MAX)?,
                agents: opt_count(&v, "agents", throng::error::MAX_AGENTS as u64)?
                    .map(|n| n as usize),
            },
            "goal" => Control::Goal {
                field: index("field")?,
                channel: index("channel")?,
                at: point(&v, "x", "y")?,
            },
            "shuffle_goals" => Control::ShuffleGoals {
                field: index("field")?,
            },
            "gravity" => Control::Gravity {
                at: point(&v, "x", "y")?,
                strength: number(&v, "strength")? as f32,
                radius: opt_number(&v, "radius")?.map(|r| r as f32),
                exponent: opt_number(&v, "exponent")?.map(|e| e as f32),
            },
            "wall" => Control::Wall {
                a: point(&v, "x0", "y0")?,
                b: point(&v, "x1", "y1")?,
            },
            "circle" => Control::Circle {
                at: point(&v, "x", "y")?,
                radius: number(&v, "radius")? as f32,
            },
            other => {
                return Err(format!(
                    "unknown cmd `{other}` (known: pause, play, step, steps_per_frame, realtime, reset, goal, shuffle_goals, gravity, wall, circle)"
                ));
            }
        })
    }
}

/// The free cell of `grid` nearest to `p` within [`GOAL_SNAP_CELLS`], if any.
fn nearest_free_cell(grid: &OccupancyGrid, p: Vec2) -> Result<(u32, u32), String> {
    let Some((cx, cy)) = grid.world_to_cell(p) else {
        return Err(format!("({}, {}) is outside the field's grid", p.x, p.y));
    };
    let mut best: Option<(i64, (u32, u32))> = None;
    for dy in -GOAL_SNAP_CELLS..=GOAL_SNAP_CELLS {
        for dx in -GOAL_SNAP_CELLS..=GOAL_SNAP_CELLS {
            let (x, y) = (i64::from(cx) + dx, i64::from(cy) + dy);
            let (Ok(x), Ok(y)) = (u32::try_from(x), u32::try_from(y)) else {
                continue;
            };
            let d = dx * dx + dy * dy;
            if grid.is_free(x, y) && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, (x, y)));
            }
        }
    }
    best.map(|(_, c)| c).ok_or_else(|| {
        format!("cell ({cx}, {cy}) is a wall and no free cell is within {GOAL_SNAP_CELLS} cells")
    })
}

/// How the simulation thread was set up.
#[derive(Debug)]
pub struct Setup {
    /// The scenario as loaded, before the command line's overrides.
    pub base: Scenario,
    /// The command line's overrides (a reset changes its seed and agent count).
    pub common: WorldArgs,
    /// The scenario's name.
    pub name: String,
    /// Time step, seconds.
    pub dt: f32,
    /// Memory the world may take (a reset is checked against it).
    pub memory: Option<u64>,
    /// Worker threads of `pool`.
    pub threads: usize,
    /// Start paused.
    pub paused: bool,
    /// Pace to the wall clock.
    pub realtime: bool,
    /// Steps between frames.
    pub steps_per_frame: u64,
}

/// The simulation thread's state.
#[derive(Debug)]
pub struct Sim {
    setup: Setup,
    world: World,
    pool: rayon::ThreadPool,
    shared: Arc<Shared>,
    version: u32,
    rebuilds: u64,
    shuffles: u64,
    info: FrameInfo,
    /// `(when, steps)` of the frames of the last second, for the wall-clock step rate.
    recent: VecDeque<(Instant, u64)>,
    error: Option<String>,
    buf: Vec<u8>,
}

impl Sim {
    /// The simulation of `world`, publishing into `shared`.
    pub fn new(setup: Setup, world: World, pool: rayon::ThreadPool, shared: Arc<Shared>) -> Self {
        let info = FrameInfo {
            paused: setup.paused,
            steps_per_frame: setup.steps_per_frame as u32,
            ..FrameInfo::default()
        };
        let mut sim = Sim {
            rebuilds: world.field_rebuilds(),
            setup,
            world,
            pool,
            shared,
            version: 1,
            shuffles: 0,
            info,
            recent: VecDeque::new(),
            error: None,
            buf: Vec::new(),
        };
        sim.publish_world();
        sim.publish_frame();
        sim
    }

    /// Steps and serves controls until [`Shared::stop`] is set or every sender is gone.
    pub fn run(mut self, rx: &Receiver<Request>) {
        let mut next = Instant::now();
        while !self.shared.stop.load(Ordering::Relaxed) {
            let wait = if self.setup.paused {
                Duration::from_millis(50)
            } else if self.setup.realtime {
                next.saturating_duration_since(Instant::now())
            } else {
                Duration::ZERO
            };
            match rx.recv_timeout(wait) {
                Ok(req) => {
                    self.handle(req);
                    continue;
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            if self.setup.paused || (self.setup.realtime && Instant::now() < next) {
                continue;
            }
            let start = Instant::now();
            self.advance(self.setup.steps_per_frame, Some(rx));
            let period = f64::from(self.setup.dt) * self.setup.steps_per_frame as f64;
            next = start + Duration::from_secs_f64(period.min(10.0));
            self.publish_frame();
        }
    }

    /// Runs up to `n` steps (fewer when a step fails or the server stops), serving the controls
    /// that arrive between steps when `rx` is given (and then stopping early when one pauses).
    fn advance(&mut self, n: u64, rx: Option<&Receiver<Request>>) {
        let mut total = 0.0;
        let mut phases = [0.0; PhaseTimes::COUNT];
        let mut done = 0u64;
        for _ in 0..n {
            let (pool, world, dt) = (&self.pool, &mut self.world, self.setup.dt);
            match pool.install(|| world.step(dt)) {
                Ok(stats) => {
                    total += stats.total_ms();
                    for (p, v) in phases.iter_mut().zip(stats.phases.as_ms()) {
                        *p += v;
                    }
                    done += 1;
                }
                Err(e) => {
                    self.error = Some(format!("step failed: {e}"));
                    self.setup.paused = true;
                    break;
                }
            }
            if let Some(rx) = rx {
                while let Ok(req) = rx.try_recv() {
                    self.handle(req);
                }
                if self.setup.paused {
                    break;
                }
            }
            if self.shared.stop.load(Ordering::Relaxed) {
                break;
            }
        }
        if done > 0 {
            let k = done as f64;
            self.info.step_ms = total / k;
            // The frame carries the pipeline's and the hooks' phases; nothing is measured here.
            self.info.phases_ms = std::array::from_fn(|i| phases[i] / k);
            self.info.agent_steps_per_sec = if total > 0.0 {
                self.world.len() as f64 * k * 1e3 / total
            } else {
                0.0
            };
            self.recent.push_back((Instant::now(), done));
        }
        if self.world.field_rebuilds() != self.rebuilds {
            self.rebuilds = self.world.field_rebuilds();
            self.changed();
        }
    }

    /// Applies one control and answers it.
    fn handle(&mut self, (control, reply): Request) {
        let result = self.apply(control).map(|()| {
            self.publish_frame();
            lock(&self.shared.state).as_ref().clone()
        });
        let _ = reply.send(result);
    }

    /// The geometry changed: a new version, and the new `/world`.
    fn changed(&mut self) {
        self.version = self.version.wrapping_add(1);
        self.publish_world();
    }

    fn apply(&mut self, control: Control) -> Result<(), String> {
        let text = |e: throng::Error| e.to_string();
        match control {
            Control::Pause => self.setup.paused = true,
            Control::Play => {
                self.setup.paused = false;
                self.error = None;
            }
            Control::Step(n) => {
                self.setup.paused = true;
                self.advance(n, None);
            }
            Control::StepsPerFrame(n) => self.setup.steps_per_frame = n,
            Control::Realtime(on) => self.setup.realtime = on,
            Control::Reset { seed, agents } => {
                let mut common = self.setup.common.clone();
                common.seed = seed.or(common.seed);
                common.agents = agents.or(common.agents);
                let s = crate::with_overrides(self.setup.base.clone(), &common).map_err(text)?;
                self.world = crate::build_world(&s, self.setup.memory).map_err(text)?;
                self.setup.common = common;
                self.rebuilds = self.world.field_rebuilds();
                self.error = None;
                self.info = FrameInfo {
                    steps_per_frame: self.info.steps_per_frame,
                    ..FrameInfo::default()
                };
                self.changed();
            }
            Control::Goal { field, channel, at } => {
                let Some(channels) = self.world.field(field) else {
                    return Err(self.no_field(field));
                };
                let cell = nearest_free_cell(channels.grid(), at)?;
                self.world
                    .set_field_goals(field, channel, &[cell])
                    .map_err(text)?;
                self.changed();
            }
            Control::ShuffleGoals { field } => {
                let Some(channels) = self.world.field(field) else {
                    return Err(self.no_field(field));
                };
                let counts: Vec<usize> = (0..channels.len())
                    .map(|c| channels.goals(c).map_or(1, |g| g.len().max(1)))
                    .collect();
                self.shuffles += 1;
                for (c, n) in counts.into_iter().enumerate() {
                    let seed =
                        self.world.seed() ^ self.shuffles.wrapping_mul(0x9E37_79B9_7F4A_7C15);
                    self.world
                        .randomize_field_goals(field, c, n, seed.wrapping_add(c as u64))
                        .map_err(text)?;
                }
                self.changed();
            }
            Control::Gravity {
                at,
                strength,
                radius,
                exponent,
            } => {
                let radius = radius.unwrap_or_else(|| {
                    self.world
                        .bounds()
                        .size()
                        .map_or(20.0, |s| s.x.max(s.y) / 10.0)
                });
                let p = GravityPoint::fixed(at, strength, exponent.unwrap_or(2.0), radius);
                self.world.add_gravity_point(p).map_err(text)?;
                self.changed();
            }
            Control::Wall { a, b } => {
                self.world.add_wall(Wall { a, b }).map_err(text)?;
                self.changed();
            }
            Control::Circle { at, radius } => {
                self.world
                    .add_circle(Circle::new(at, radius))
                    .map_err(text)?;
                self.changed();
            }
        }
        Ok(())
    }

    fn no_field(&self, field: usize) -> String {
        match self.world.field_count() {
            0 => "this world has no field (goal clicks need a scenario with [field])".into(),
            n => format!("no field {field}: this world has {n}"),
        }
    }

    /// Regenerates `GET /world`.
    fn publish_world(&mut self) {
        let body = frame::world_json(&self.world, self.version).to_string();
        *lock(&self.shared.world) = Arc::new(body);
    }

    /// Encodes the current frame, offers it to every client (dropping it for a client whose
    /// queue is full, forgetting a client that has gone) and regenerates `GET /state`.
    fn publish_frame(&mut self) {
        self.info.paused = self.setup.paused;
        self.info.world_version = self.version;
        self.info.steps_per_frame = self.setup.steps_per_frame as u32;
        frame::encode(&self.world, &self.info, &mut self.buf);
        let f: Frame = Arc::new(self.buf.clone());
        let clients = {
            let mut clients = lock(&self.shared.clients);
            clients
                .retain(|tx| !matches!(tx.try_send(f.clone()), Err(TrySendError::Disconnected(_))));
            clients.len()
        };
        *lock(&self.shared.latest) = Some(f);
        let state = self.state_json(clients).to_string();
        *lock(&self.shared.state) = Arc::new(state);
    }

    /// The `GET /state` object.
    fn state_json(&mut self, clients: usize) -> Value {
        let now = Instant::now();
        while self
            .recent
            .front()
            .is_some_and(|(t, _)| now.duration_since(*t) > Duration::from_secs(1))
        {
            self.recent.pop_front();
        }
        let steps_per_sec: u64 = self.recent.iter().map(|(_, n)| n).sum();
        let phases: serde_json::Map<String, Value> = PhaseTimes::NAMES
            .iter()
            .zip(self.info.phases_ms)
            .map(|(name, ms)| ((*name).to_string(), json!(ms)))
            .collect();
        let (goals, goal_points) = match self.world.field(0) {
            Some(ch) => {
                let cells = ch.goals(0).unwrap_or(&[]);
                let points: Vec<Value> = cells
                    .iter()
                    .map(|&(x, y)| {
                        let p = ch.grid().cell_center(x, y);
                        json!([p.x, p.y])
                    })
                    .collect();
                (json!(cells), Value::Array(points))
            }
            None => (Value::Null, Value::Null),
        };
        json!({
            "scenario": self.setup.name,
            "frame": self.world.frame(),
            "time": self.world.time(),
            "paused": self.setup.paused,
            "realtime": self.setup.realtime,
            "steps_per_frame": self.setup.steps_per_frame,
            "agents": self.world.len(),
            "seed": self.world.seed(),
            "dt": self.setup.dt,
            "threads": self.setup.threads,
            "world_version": self.version,
            "timings": {
                "ms_per_step": self.info.step_ms,
                "phases_ms": phases,
                "agent_steps_per_sec": self.info.agent_steps_per_sec,
                "steps_per_sec": steps_per_sec,
            },
            "goals": goals,
            "goal_points": goal_points,
            "field_rebuilds": self.world.field_rebuilds(),
            "gravity_points": self.world.gravity().points().len(),
            "walls": self.world.obstacles().walls().len(),
            "circles": self.world.obstacles().circles().len(),
            "clients": clients,
            "error": self.error,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_simulation_thread_that_panics_leaves_its_error_in_the_state() {
        let shared = Shared::default();
        *lock(&shared.state) = Arc::new(r#"{"frame":7,"paused":false,"error":null}"#.into());
        guarded(&shared, || {});
        assert!(lock(&shared.state).contains(r#""error":null"#));
        guarded(&shared, || {
            panic!("index out of bounds: the len is 4 but the index is 5")
        });
        let v: Value = serde_json::from_str(&lock(&shared.state)).unwrap();
        let error = v["error"].as_str().expect("an error");
        assert!(error.contains("index out of bounds"), "{error}");
        assert_eq!(v["paused"], json!(true));
        assert_eq!(v["frame"], json!(7));
    }

    #[test]
    fn controls_parse_and_bad_ones_name_the_problem() {
        assert_eq!(Control::parse(br#"{"cmd":"pause"}"#), Ok(Control::Pause));
        assert_eq!(Control::parse(br#"{"cmd":"step"}"#), Ok(Control::Step(1)));
        assert_eq!(
            Control::parse(br#"{"cmd":"goal","x":1.5,"y":2}"#),
            Ok(Control::Goal {
                field: 0,
                channel: 0,
                at: Vec2::new(1.5, 2.0)
            })
        );
        let err = |body: &[u8]| Control::parse(body).unwrap_err();
        assert!(err(b"{").contains("not JSON"));
        assert!(err(b"[1]").contains("`cmd`"));
        assert!(err(br#"{"cmd":"fly"}"#).contains("unknown cmd `fly`"));
        assert!(err(br#"{"cmd":"goal","x":1}"#).contains("`y` is missing"));
        assert!(err(br#"{"cmd":"goal","x":"a","y":1}"#).contains("`x` must be a number"));
        assert!(err(br#"{"cmd":"step","n":0}"#).contains("at least 1"));
        assert!(err(br#"{"cmd":"step","n":1001}"#).contains("from 0 to 1000"));
        assert!(err(br#"{"cmd":"steps_per_frame"}"#).contains("`n` is missing"));
        assert!(err(br#"{"cmd":"reset","agents":-3}"#).contains("`agents`"));
    }

    #[test]
    fn goal_clicks_snap_to_the_nearest_free_cell() {
        let grid = OccupancyGrid::parse_ascii("....\n.###\n.###\n", "<map>")
            .unwrap()
            .grid;
        let free = nearest_free_cell(&grid, grid.cell_center(0, 0)).unwrap();
        assert_eq!(free, (0, 0));
        let snapped = nearest_free_cell(&grid, grid.cell_center(2, 1)).unwrap();
        assert!(grid.is_free(snapped.0, snapped.1));
        let far = Vec2::new(-100.0, -100.0);
        assert!(
            nearest_free_cell(&grid, far)
                .unwrap_err()
                .contains("outside")
        );
    }
}
