//! The pedestrian models of the steering layer: after the steering pass, every agent of a group
//! with [`Pedestrian`] parameters has its request replaced by what its model asks
//! ([`crate::ped`]): the social force model's acceleration or the collision-free speed model's
//! velocity, from the behaviours' preferred direction, the agent's desired speed, the agents
//! within the model's cut-off (through the world's neighbour index) and the walls and circles
//! within it (through the obstacles' broad phase).
//!
//! Per agent, the neighbours within the cut-off are gathered first (from the grid's own sorted
//! positions, [`GridIndex::sorted_padded`], eight candidates at a time), then their pair terms
//! are evaluated eight at a time in lanes ([`crate::ped::lanes`]) and summed per lane, the lanes
//! added in a fixed order at the end.
//!
//! Runs before the ORCA filter, so a group with both walks by its pedestrian model and ORCA
//! keeps the result collision-free.
//!
//! Invariants: reads frame-t positions and velocities and the agent's own request only, writes
//! only the agent's own request, sums neighbours in the index's order and walls in index order,
//! so the result does not depend on the thread count; per-worker buffers are reused, so a warm
//! step allocates nothing.

use std::cell::RefCell;
use std::ops::Range;

use glam::Vec2;
use rayon::prelude::*;

use super::out::{STEER_CHUNK, SteerOut};
use super::pack::{Packed, pack_block};
use super::view::SteerView;
use crate::agents::Agents;
use crate::ped::cfsm::{BLOCKED_SPACING, SIDESTEP_WALL_MARGIN};
use crate::ped::lanes::{LANES, Neighbours, behind_lanes, lane_sum};
use crate::ped::own::own;
use crate::ped::{Cfsm, ModelParams, Pedestrian, SocialForce};
use crate::simd::{apply, float_kernel};
use crate::spatial::{GridIndex, Neighbour, NeighbourIndex, SORTED_PAD, SpatialIndex};
use crate::steering::truncate;

// The candidate scan (`gather`) reads the grid's sorted positions in whole blocks of `LANES`,
// up to `LANES - 1` values past a run's end: the grid's padding must hold them.
const _: () = assert!(SORTED_PAD >= LANES);

/// One worker's buffers.
#[derive(Default)]
struct Buffers {
    found: Vec<Neighbour>,
    /// The grid's runs of candidates.
    runs: Vec<Range<usize>>,
    /// The agents within the cut-off, padded to whole blocks of [`LANES`]: `x_j - x_i`, x.
    rx: Vec<f32>,
    /// `x_j - x_i`, y.
    ry: Vec<f32>,
    /// `j`.
    js: Vec<u32>,
    /// `r_i + r_j`.
    reach: Vec<f32>,
    /// The x direction at zero distance (`Pairs::side`).
    side: Vec<f32>,
    /// `j`'s velocity (the social force model's friction).
    vx: Vec<f32>,
    vy: Vec<f32>,
    /// `|x_j - x_i|` (the speed model's spacing).
    dist: Vec<f32>,
    /// The pair terms, x.
    fx: Vec<f32>,
    /// The pair terms, y.
    fy: Vec<f32>,
    walls: Vec<u32>,
    circles: Vec<u32>,
    /// The walls within reach: index, closest point, and whether that point is an end.
    near_walls: Vec<(u32, Vec2, bool)>,
}

thread_local! {
    static BUFFERS: RefCell<Buffers> = RefCell::new(Buffers::default());
}

/// Whether some plan moves its agents by a pedestrian model.
pub(crate) fn any(view: &SteerView) -> bool {
    view.plans.iter().any(|p| p.pedestrian.is_some())
}

/// Replaces the requests in `out` of every agent whose group uses a pedestrian model.
pub(crate) fn run(view: &SteerView, out: &mut SteerOut, parallel: bool) {
    let n = view.agents.len();
    let grid = match view.index {
        SpatialIndex::Grid(g) if !view.bounds.is_torus() && g.len() == n => Some(g),
        _ => None,
    };
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    let avx2 = false;
    let radii = Radii::of(&view.agents.radius);
    let chunk = |base: usize, lx: &mut [f32], ly: &mut [f32]| {
        BUFFERS.with_borrow_mut(|b| requests(view, grid, avx2, radii, base, lx, ly, b));
    };
    let (lx, ly) = (&mut out.lin_x[..n], &mut out.lin_y[..n]);
    if parallel {
        lx.par_chunks_mut(STEER_CHUNK)
            .zip(ly.par_chunks_mut(STEER_CHUNK))
            .enumerate()
            .for_each(|(c, (x, y))| chunk(c * STEER_CHUNK, x, y));
    } else {
        chunk(0, lx, ly);
    }
}

/// The requests of agents `base..base + lx.len()`, replaced where the group has a model.
#[apply(float_kernel!)]
#[allow(clippy::too_many_arguments)]
fn requests(
    view: &SteerView,
    grid: Option<&GridIndex>,
    avx2: bool,
    radii: Radii,
    base: usize,
    lx: &mut [f32],
    ly: &mut [f32],
    b: &mut Buffers,
) {
    for k in 0..lx.len() {
        let i = base + k;
        let g = view.agents.group[i] as usize;
        if let Some(group) = &view.plans[g].pedestrian {
            let own = own(view.model_params, view.agents.ids[i], group);
            let ped = own.as_ref().unwrap_or(group);
            let r = agent(view, grid, avx2, radii, ped, i, Vec2::new(lx[k], ly[k]), b);
            lx[k] = r.x;
            ly[k] = r.y;
        }
    }
}

/// Calls `f(d, normal)` for every wall and circle within `r` of `pos`, in index order: `d` runs
/// from the obstacle's closest point to `pos`, `normal` is the direction to use when `d` is zero
/// (a wall's normal is only worked out then; otherwise `normal` is `Vec2::Y`, unused).
///
/// A corner is one point of the boundary, not one per wall: a wall whose closest point is an
/// end it shares with another wall within reach is skipped when that other wall's closest point
/// lies inside it (at least as near, since the corner is on it too) or is the same corner and
/// the other wall comes first. So a body beside a door's jamb is repelled by the wall it faces
/// and not again by the end of the wall round the corner, and a body in the wedge outside a
/// corner by that corner once.
#[inline(always)]
fn for_each_wall(
    view: &SteerView,
    pos: Vec2,
    r: f32,
    b: &mut Buffers,
    mut f: impl FnMut(Vec2, Vec2),
) {
    let obstacles = view.obstacles;
    if obstacles.is_empty() {
        return;
    }
    obstacles
        .broadphase()
        .near(pos, r, &mut b.circles, &mut b.walls);
    let r_sq = r * r;
    b.near_walls.clear();
    for &w in &b.walls {
        let wall = obstacles.walls()[w as usize];
        let (c, at_end) = wall.closest_point_or_end(pos);
        if (pos - c).length_squared() <= r_sq {
            b.near_walls.push((w, c, at_end));
        }
    }
    for (k, &(w, c, at_end)) in b.near_walls.iter().enumerate() {
        let corner_counted = at_end
            && b.near_walls
                .iter()
                .enumerate()
                .any(|(m, &(v, cv, v_at_end))| {
                    let other = obstacles.walls()[v as usize];
                    m != k && (other.a == c || other.b == c) && (!v_at_end || (cv == c && m < k))
                });
        if corner_counted {
            continue;
        }
        let wall = obstacles.walls()[w as usize];
        let d = pos - c;
        // The models use the normal only where `d.length() <= 1e-6`.
        let normal = if d.length() > 1e-6 {
            Vec2::Y
        } else {
            (wall.b - wall.a).perp().normalize_or(Vec2::Y)
        };
        f(d, normal);
    }
    for &c in &b.circles {
        let circle = obstacles.circles()[c as usize];
        let to = pos - circle.center;
        let dist = to.length();
        let n = if dist > 1e-6 { to / dist } else { Vec2::X };
        let gap = (dist - circle.radius).max(0.0);
        if gap <= r {
            f(n * gap, n);
        }
    }
}

/// Makes `v` at least `n` long (buffers only grow, so a warm step neither allocates nor
/// clears them).
#[inline(always)]
fn at_least<T: Copy + Default>(v: &mut Vec<T>, n: usize) {
    if v.len() < n {
        v.resize(n, T::default());
    }
}

/// Gathers agent `i`'s neighbours `j != i` within `r`, in the index's order, into `b` (`rx`,
/// `ry`, `js`), padded to a whole number of blocks with lanes of `i` itself; returns their count
/// and the padded length.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn gather(
    view: &SteerView,
    grid: Option<&GridIndex>,
    avx2: bool,
    i: usize,
    pos: Vec2,
    r: f32,
    b: &mut Buffers,
) -> (usize, usize) {
    let mut count = 0;
    match grid {
        Some(grid) => {
            // The runs first, so the scan below is compiled here, with this function's lanes.
            b.runs.clear();
            let mut candidates = 0;
            grid.for_each_run(pos, r, |run| {
                candidates += run.len();
                b.runs.push(run);
            });
            at_least(&mut b.rx, candidates + LANES);
            at_least(&mut b.ry, candidates + LANES);
            at_least(&mut b.js, candidates + LANES);
            let (rx, ry, js) = (&mut b.rx[..], &mut b.ry[..], &mut b.js[..]);
            let order = grid.order();
            let (sx, sy) = grid.sorted_padded();
            let r_sq = r * r;
            for run in &b.runs {
                // The grid's positions are padded with a block of zeros, so every block of a
                // run is read whole, in lanes, its tail masked off, and the lanes within the
                // cut-off packed without a branch per lane (`plans::pack`).
                let mut at = run.start;
                while at < run.end {
                    let xs: &[f32; LANES] = sx[at..at + LANES].try_into().expect("a block");
                    let ys: &[f32; LANES] = sy[at..at + LANES].try_into().expect("a block");
                    let mut out = Packed {
                        rx,
                        ry,
                        js,
                        p: (pos.x, pos.y),
                        r_sq,
                        me: i as u32,
                    };
                    let left = run.end - at;
                    count = pack_block(xs, ys, order, at, left, &mut out, count, avx2);
                    at += LANES;
                }
            }
        }
        None => {
            view.index.neighbours_at(pos, r, &mut b.found);
            at_least(&mut b.rx, b.found.len() + LANES);
            at_least(&mut b.ry, b.found.len() + LANES);
            at_least(&mut b.js, b.found.len() + LANES);
            for nb in &b.found {
                let j = nb.index as usize;
                if j != i {
                    let rel = view.bounds.offset(pos, view.agents.position(j));
                    (b.rx[count], b.ry[count], b.js[count]) = (rel.x, rel.y, j as u32);
                    count += 1;
                }
            }
        }
    }
    // A whole block of padding from `count` on (the buffers have room for it): what lies past
    // the padded length is never read.
    b.rx[count..count + LANES].fill(0.0);
    b.ry[count..count + LANES].fill(0.0);
    b.js[count..count + LANES].fill(i as u32);
    (count, count.div_ceil(LANES) * LANES)
}

/// The agents' radii as the pair inputs need them: the largest, and the one every agent has
/// when they are all equal.
#[derive(Clone, Copy, Debug)]
struct Radii {
    uniform: Option<f32>,
    max: f32,
}

impl Radii {
    fn of(radius: &[f32]) -> Radii {
        let (lo, hi) = radius
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &r| {
                (lo.min(r), hi.max(r))
            });
        Radii {
            uniform: (lo == hi).then_some(hi),
            max: hi.max(0.0),
        }
    }
}

/// The smallest squared distance of the first `count` of the `n` gathered neighbours (a whole
/// number of blocks; infinity for none), block by block in lanes. A minimum does not depend on
/// the order it is taken in: the bits of one neighbour after the other (the tests'
/// `nearest_sq_reference`).
#[inline(always)]
fn nearest_sq(b: &Buffers, count: usize, n: usize) -> f32 {
    let mut best = [f32::INFINITY; LANES];
    // The count as a float, as the speed model's spacing counts its lanes (exact below 2^24).
    let mut left = count as f32;
    let blocks = b.rx[..n]
        .chunks_exact(LANES)
        .zip(b.ry[..n].chunks_exact(LANES));
    for (xs, ys) in blocks {
        let xs: &[f32; LANES] = xs.try_into().expect("a block");
        let ys: &[f32; LANES] = ys.try_into().expect("a block");
        for l in 0..LANES {
            let d = xs[l] * xs[l] + ys[l] * ys[l];
            let real = (l as f32) < left;
            // `f32::min` for finite offsets, in a form that stays in lanes.
            best[l] = if real & (d < best[l]) { d } else { best[l] };
        }
        left -= LANES as f32;
    }
    best.into_iter()
        .fold(f32::INFINITY, |m, d| if d < m { d } else { m })
}

/// Fills the pair inputs of the first `n` gathered neighbours (`count` of them real, the rest
/// padding) that the lanes read: `r_i + r_j`, the direction at zero distance, and
/// (`with_velocity`) `j`'s velocity. Returns whether some neighbour may touch the agent (with
/// `with_velocity` only; false otherwise).
///
/// Only what a lane's result can depend on is read from the agents: the direction at zero
/// distance only when some neighbour is that close (elsewhere the lanes never select it), the
/// velocities only when some neighbour may touch (the friction scales them by the contact, zero
/// elsewhere, and without a touch the lanes leave the contact terms out and do not read them),
/// and `r_i + r_j` as one number when every agent has the same radius.
#[inline(always)]
fn fill(
    a: &Agents,
    radii: Radii,
    i: usize,
    b: &mut Buffers,
    (count, n): (usize, usize),
    with_velocity: bool,
) -> bool {
    let (radius, id) = (a.radius[i], a.ids[i].0);
    at_least(&mut b.reach, n);
    at_least(&mut b.side, n);
    match radii.uniform {
        Some(r) => b.reach[..n].fill(radius + r),
        None => {
            for (&j, reach) in b.js[..n].iter().zip(&mut b.reach[..n]) {
                *reach = radius + a.radius[j as usize];
            }
        }
    }
    let nearest = nearest_sq(b, count, n);
    // `d > 1e-6` in the lanes holds wherever `d^2` exceeds 1e-10.
    if nearest <= 1e-10 {
        for (&j, side) in b.js[..n].iter().zip(&mut b.side[..n]) {
            *side = if id < a.ids[j as usize].0 { 1.0 } else { -1.0 };
        }
    }
    if with_velocity {
        at_least(&mut b.vx, n);
        at_least(&mut b.vy, n);
        // A margin over `r_i + r_max` for the rounding of the lanes' square root.
        let touch = (radius + radii.max) * 1.001;
        if nearest <= touch * touch {
            let slots = b.js[..n].iter().zip(&mut b.vx[..n]).zip(&mut b.vy[..n]);
            for ((&j, vx), vy) in slots {
                *vx = a.vel_x[j as usize];
                *vy = a.vel_y[j as usize];
            }
            return true;
        }
    }
    false
}

/// The first `n` filled neighbours, `count` of them real, as the lanes read them.
#[inline(always)]
fn neighbours(b: &Buffers, count: usize, n: usize) -> Neighbours<'_> {
    Neighbours {
        count,
        rx: &b.rx[..n],
        ry: &b.ry[..n],
        reach: &b.reach[..n],
        side: &b.side[..n],
    }
}

/// The social force model's pair forces on an agent with velocity `v` and preferred direction
/// `e` from its `count` filled neighbours (`n` with the padding); without the contact terms
/// when no neighbour may touch (`touching` false, as [`fill`] finds it).
#[apply(float_kernel!)]
#[allow(clippy::too_many_arguments)]
fn social_force_sum(
    sf: &SocialForce,
    b: &mut Buffers,
    count: usize,
    n: usize,
    v: Vec2,
    e: Vec2,
    dt: f32,
    touching: bool,
) -> Vec2 {
    // The outputs leave the buffers while the lanes read the inputs.
    let (mut fx, mut fy) = (std::mem::take(&mut b.fx), std::mem::take(&mut b.fy));
    at_least(&mut fx, n);
    at_least(&mut fy, n);
    let vel = (&b.vx[..n], &b.vy[..n]);
    let (v, e) = ((v.x, v.y), (e.x, e.y));
    let (sx, sy) = (&mut fx[..n], &mut fy[..n]);
    let nb = neighbours(b, count, n);
    if touching {
        sf.pair_lanes::<true>(&nb, vel, v, e, dt, sx, sy);
    } else {
        sf.pair_lanes::<false>(&nb, vel, v, e, dt, sx, sy);
    }
    let sum = Vec2::new(lane_sum(sx), lane_sum(sy));
    (b.fx, b.fy) = (fx, fy);
    sum
}

/// The speed model's repulsion of the `count` filled neighbours (`n` with the padding) on an
/// agent with the preferred direction `e0`, under the anisotropy the pressure about `e0` gives
/// ([`Cfsm::anisotropy_at`]); keeps their distances in `b.dist` for the spacing.
#[apply(float_kernel!)]
fn speed_model_sum(cf: &Cfsm, b: &mut Buffers, count: usize, n: usize, e0: Vec2) -> Vec2 {
    let lambda = if cf.pressed_anisotropy_on() {
        let behind = behind_lanes((e0.x, e0.y), &neighbours(b, count, n));
        cf.anisotropy_at(cf.pressure(behind, count as f32))
    } else {
        cf.anisotropy
    };
    at_least(&mut b.fx, n);
    at_least(&mut b.fy, n);
    at_least(&mut b.dist, n);
    // The outputs borrowed beside the inputs, field by field.
    let Buffers {
        rx,
        ry,
        reach,
        side,
        fx,
        fy,
        dist,
        ..
    } = b;
    let nb = Neighbours {
        count,
        rx: &rx[..n],
        ry: &ry[..n],
        reach: &reach[..n],
        side: &side[..n],
    };
    let (sx, sy) = (&mut fx[..n], &mut fy[..n]);
    cf.repulsion_lanes(&nb, sx, sy, &mut dist[..n], (e0.x, e0.y), lambda);
    Vec2::new(lane_sum(sx), lane_sum(sy))
}

/// The smallest spacing along `e` to the `count` filled neighbours ([`Cfsm::spacing_to`]) and
/// how many of them lie behind.
#[apply(float_kernel!)]
fn speed_model_spacing(cf: &Cfsm, b: &Buffers, count: usize, n: usize, e: Vec2) -> (f32, f32) {
    cf.min_spacing_lanes((e.x, e.y), &neighbours(b, count, n), &b.dist[..n])
}

/// At most this many obstacles near an agent's body are kept for its sidestep.
const NEAR_WALLS: usize = 8;

/// The turns a blocked pedestrian tries, `(cos, sin)`: 45 degrees, then 90.
const SIDESTEP_TURNS: [(f32, f32); 2] = [
    (
        std::f32::consts::FRAC_1_SQRT_2,
        std::f32::consts::FRAC_1_SQRT_2,
    ),
    (0.0, 1.0),
];

/// Agent `i`'s request under its pedestrian model, given the behaviours' request.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn agent(
    view: &SteerView,
    grid: Option<&GridIndex>,
    avx2: bool,
    radii: Radii,
    ped: &Pedestrian,
    i: usize,
    request: Vec2,
    b: &mut Buffers,
) -> Vec2 {
    let a = view.agents;
    let adapter = &view.plans[a.group[i] as usize].adapter;
    let dt = view.dt;
    let pos = a.position(i);
    let vel = a.velocity(i);
    let radius = a.radius[i];
    let max_speed = a.max_speed[i];

    // The preferred direction, and the desired speed (a kinematic group's behaviours may ask
    // for less than the maximum speed, as `arrive` does near its target).
    let pref = if adapter.kinematic {
        request
    } else {
        vel + request * dt
    };
    let len = pref.length();
    let (e0, v0) = if len > 1e-6 && len.is_finite() {
        let scale = if adapter.kinematic {
            (len / max_speed).min(1.0)
        } else {
            1.0
        };
        (pref / len, a.desired_speed[i] * scale)
    } else {
        (Vec2::ZERO, 0.0)
    };
    // Before its pre-movement time a pedestrian does not walk.
    let waiting = ped.waits(view.seed, a.ids[i].0, view.time);
    let (e0, v0) = if waiting { (Vec2::ZERO, 0.0) } else { (e0, v0) };
    let (count, n) = gather(view, grid, avx2, i, pos, ped.cutoff(), b);
    #[cfg(feature = "oracle")]
    crate::oracle::record(crate::oracle::Seen {
        model: "pedestrian",
        agent: a.ids[i].0,
        position: pos,
        radius: ped.cutoff(),
        nearest: None,
        neighbours: b.js[..count].iter().map(|&j| a.ids[j as usize].0).collect(),
    });

    let chosen_velocity = match &ped.params {
        ModelParams::SocialForce(sf) => {
            // The social repulsion (from agents and from walls) is a pedestrian's own motive to
            // keep its distance, and a waiting one has no motives yet: only the body force and
            // the friction of contact move it.
            let still;
            let sf = if waiting {
                still = SocialForce {
                    a: 0.0,
                    a_wall: 0.0,
                    ..*sf
                };
                &still
            } else {
                sf
            };
            let touching = fill(a, radii, i, b, (count, n), true);
            let force = social_force_sum(sf, b, count, n, vel, e0, dt, touching);
            let mut walls = Vec2::ZERO;
            for_each_wall(view, pos, sf.cutoff, b, |d, normal| {
                walls += sf.wall(d, vel, radius, normal, dt);
            });
            let acc = sf.driving(v0, e0, vel) + (force + walls) / sf.mass;
            if !adapter.kinematic {
                return finite_or_zero(truncate(acc, adapter.max_acceleration));
            }
            vel + acc * dt
        }
        ModelParams::Cfsm(cf) => {
            fill(a, radii, i, b, (count, n), false);
            let mut dir = e0 + speed_model_sum(cf, b, count, n, e0);
            // The obstacles touching the body or nearly: the sidestep does not turn into them.
            let mut near = [Vec2::ZERO; NEAR_WALLS];
            let mut near_count = 0;
            for_each_wall(view, pos, cf.cutoff, b, |d, normal| {
                dir += cf.wall(d, radius, normal);
                if cf.sidestep && near_count < NEAR_WALLS {
                    let dist = d.length();
                    if dist < radius + SIDESTEP_WALL_MARGIN {
                        near[near_count] = if dist > 1e-6 { d / dist } else { normal };
                        near_count += 1;
                    }
                }
            });
            let mut e = dir.normalize_or_zero();
            let (mut spacing, behind) = speed_model_spacing(cf, b, count, n, e);
            if cf.sidestep && spacing <= BLOCKED_SPACING && v0 > 0.0 && e != Vec2::ZERO {
                let first = if e.perp_dot(e0) < 0.0 { -1.0 } else { 1.0 };
                let walls = &near[..near_count];
                'turns: for (cos, sin) in SIDESTEP_TURNS {
                    for side in [first, -first] {
                        let turned = Vec2::new(cos, side * sin).rotate(e);
                        if walls.iter().any(|&w| turned.dot(w) < 0.0) {
                            continue;
                        }
                        let (s, _) = speed_model_spacing(cf, b, count, n, turned);
                        if s > BLOCKED_SPACING {
                            (e, spacing) = (turned, s);
                            break 'turns;
                        }
                    }
                }
            }
            let v = e * cf.speed_under(spacing, v0, cf.pressure(behind, count as f32));
            if !adapter.kinematic {
                return finite_or_zero(truncate((v - vel) / dt, adapter.max_acceleration));
            }
            v
        }
    };
    finite_or_zero(truncate(chosen_velocity, max_speed))
}

#[inline]
fn finite_or_zero(v: Vec2) -> Vec2 {
    if v.is_finite() { v } else { Vec2::ZERO }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::agents::AgentInit;
    use crate::rng::AgentRng;

    /// The pair inputs of every neighbour read from the agents, as before the reads were
    /// skipped: the reference the skipping fill is held to.
    fn fill_all(a: &Agents, i: usize, b: &mut Buffers, n: usize) {
        let (radius, id) = (a.radius[i], a.ids[i].0);
        for k in 0..n {
            let j = b.js[k] as usize;
            b.reach[k] = radius + a.radius[j];
            b.side[k] = if id < a.ids[j].0 { 1.0 } else { -1.0 };
            b.vx[k] = a.vel_x[j];
            b.vy[k] = a.vel_y[j];
        }
    }

    /// Agents in a small box: some on top of each other, some overlapping, the rest apart;
    /// equal radii or a spread of them.
    fn crowd(seed: u64, uniform: bool) -> Agents {
        let mut rng = AgentRng::new(seed, 0, 0, 0);
        let mut a = Agents::new();
        for k in 0..48 {
            let position = if k % 9 == 4 {
                Vec2::new(a.pos_x[k - 1], a.pos_y[k - 1])
            } else {
                Vec2::new(rng.unit(), rng.unit()) * 3.0
            };
            let init = AgentInit {
                velocity: Vec2::new(rng.signed(), rng.signed()),
                ..AgentInit::at(position, 0)
            };
            let radius = if uniform {
                0.2
            } else {
                0.15 + 0.1 * rng.unit()
            };
            a.push(&init, 2.0, radius, 0.0, 1.3);
        }
        a
    }

    /// [`nearest_sq`] one neighbour after the other (as it was before its lanes): the reference
    /// its lanes are held to.
    fn nearest_sq_reference(b: &Buffers, count: usize) -> f32 {
        let mut nearest = f32::INFINITY;
        for (&x, &y) in b.rx[..count].iter().zip(&b.ry[..count]) {
            let d = x * x + y * y;
            nearest = if d < nearest { d } else { nearest };
        }
        nearest
    }

    #[test]
    fn the_nearest_neighbour_in_lanes_is_the_nearest_one_by_one() {
        for (seed, uniform) in [(5, true), (6, false)] {
            let a = crowd(seed, uniform);
            let mut b = Buffers::default();
            for i in 0..a.len() {
                let (count, n) = gather(&a, i, 0.6 + 0.1 * (i % 20) as f32, &mut b);
                let got = nearest_sq(&b, count, n);
                assert_eq!(
                    got.to_bits(),
                    nearest_sq_reference(&b, count).to_bits(),
                    "agent {i}"
                );
            }
        }
    }

    /// Agent `i`'s neighbours within `r` in index order, padded with `i` as `gather` leaves
    /// them, with leftovers of an earlier agent past the padding.
    fn gather(a: &Agents, i: usize, r: f32, b: &mut Buffers) -> (usize, usize) {
        b.rx.clear();
        b.ry.clear();
        b.js.clear();
        for j in (0..a.len()).filter(|&j| j != i) {
            let rel = a.position(j) - a.position(i);
            if rel.length() <= r {
                b.rx.push(rel.x);
                b.ry.push(rel.y);
                b.js.push(j as u32);
            }
        }
        let count = b.js.len();
        let n = count.div_ceil(LANES) * LANES;
        b.rx.resize(n, 0.0);
        b.ry.resize(n, 0.0);
        b.js.resize(n, i as u32);
        b.rx.extend([-7.0; LANES]);
        b.ry.extend([0.0; LANES]);
        (count, n)
    }

    #[test]
    fn pair_inputs_read_only_where_they_matter_give_the_same_bits() {
        let (sf, cf) = (SocialForce::default(), Cfsm::default());
        for (seed, uniform) in [(1, true), (2, false), (3, true), (4, false)] {
            let a = crowd(seed, uniform);
            let radii = Radii::of(&a.radius);
            assert_eq!(radii.uniform.is_some(), uniform);
            let mut rng = AgentRng::new(seed, 1, 0, 0);
            for i in 0..a.len() {
                // The neighbours within the cut-off in index order, padded with `i`, as
                // `gather` leaves them; the velocities and directions left from an earlier agent.
                let (mut lazy, mut full) = (Buffers::default(), Buffers::default());
                let (count, n) = gather(&a, i, sf.cutoff, &mut lazy);
                for v in [&mut lazy.vx, &mut lazy.vy, &mut lazy.side] {
                    v.extend((0..n).map(|_| 5.0 * rng.signed()));
                }
                (full.rx, full.ry, full.js) = (lazy.rx.clone(), lazy.ry.clone(), lazy.js.clone());
                for v in [&mut full.reach, &mut full.side, &mut full.vx, &mut full.vy] {
                    v.resize(n, 0.0);
                }
                let touching = fill(&a, radii, i, &mut lazy, (count, n), true);
                fill_all(&a, i, &mut full, n);
                let (v, e) = (a.velocity(i), Vec2::new(0.6, 0.8));
                let bits = |f: Vec2| (f.x.to_bits(), f.y.to_bits());
                let want = social_force_sum(&sf, &mut full, count, n, v, e, 0.01, true);
                let got = social_force_sum(&sf, &mut lazy, count, n, v, e, 0.01, touching);
                assert_eq!(
                    bits(got),
                    bits(want),
                    "social force, agent {i}, seed {seed}"
                );
                let want = speed_model_sum(&cf, &mut full, count, n, e);
                let got = speed_model_sum(&cf, &mut lazy, count, n, e);
                assert_eq!(bits(got), bits(want), "speed model, agent {i}, seed {seed}");
                let want = speed_model_spacing(&cf, &full, count, n, e);
                let got = speed_model_spacing(&cf, &lazy, count, n, e);
                assert_eq!(
                    (got.0.to_bits(), got.1.to_bits()),
                    (want.0.to_bits(), want.1.to_bits())
                );
            }
        }
    }
}
