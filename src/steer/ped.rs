//! The pedestrian models of the steering layer: after the steering pass, every agent of a group
//! with [`Pedestrian`] parameters has its request replaced by what its model asks
//! ([`crate::ped`]): the social force model's acceleration or the collision-free speed model's
//! velocity, from the behaviours' preferred direction, the agent's desired speed, the agents
//! within the model's cut-off (through the world's neighbour index) and the walls and circles
//! within it (through the obstacles' broad phase).
//!
//! Runs before the ORCA filter, so a group with both walks by its pedestrian model and ORCA
//! keeps the result collision-free.
//!
//! Invariants: reads frame-t positions and velocities and the agent's own request only, writes
//! only the agent's own request, sums neighbours in the index's order and walls in index order,
//! so the result does not depend on the thread count; per-worker buffers are reused, so a warm
//! step allocates nothing.

use std::cell::RefCell;

use glam::Vec2;
use rayon::prelude::*;

use super::pass::{STEER_CHUNK, SteerOut};
use super::view::SteerView;
use crate::ped::{Model, Pedestrian};
use crate::spatial::{GridIndex, Neighbour, NeighbourIndex, SpatialIndex};
use crate::steering::truncate;

/// One worker's buffers.
#[derive(Default)]
struct Buffers {
    found: Vec<Neighbour>,
    /// `(x_j - x_i, r_i + r_j)` of the neighbours within the cut-off.
    near: Vec<(Vec2, f32)>,
    walls: Vec<u32>,
    circles: Vec<u32>,
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
    let chunk = |base: usize, lx: &mut [f32], ly: &mut [f32]| {
        BUFFERS.with_borrow_mut(|b| {
            for k in 0..lx.len() {
                let i = base + k;
                let g = view.agents.group[i] as usize;
                if let Some(ped) = &view.plans[g].pedestrian {
                    let r = agent(view, grid, ped, i, Vec2::new(lx[k], ly[k]), b);
                    lx[k] = r.x;
                    ly[k] = r.y;
                }
            }
        });
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

/// Calls `f(j, x_j - x_i)` for every agent `j != i` within `r` of `pos`, in the index's order.
fn for_each_near(
    view: &SteerView,
    grid: Option<&GridIndex>,
    i: usize,
    pos: Vec2,
    r: f32,
    found: &mut Vec<Neighbour>,
    mut f: impl FnMut(usize, Vec2),
) {
    let r_sq = r * r;
    match grid {
        Some(grid) => {
            let (sx, sy, order) = (grid.sorted_x(), grid.sorted_y(), grid.order());
            grid.for_each_run(pos, r, |run| {
                let (xs, ys, js) = (&sx[run.clone()], &sy[run.clone()], &order[run]);
                // Eight candidates at a time: the offsets and the hit mask in lanes, then the
                // hits in order.
                for ((xs, ys), js) in xs.chunks(8).zip(ys.chunks(8)).zip(js.chunks(8)) {
                    let (mut dx, mut dy) = ([0.0f32; 8], [0.0f32; 8]);
                    let mut hits = 0u32;
                    for l in 0..xs.len() {
                        dx[l] = xs[l] - pos.x;
                        dy[l] = ys[l] - pos.y;
                        hits |= u32::from(dx[l] * dx[l] + dy[l] * dy[l] <= r_sq) << l;
                    }
                    while hits != 0 {
                        let l = hits.trailing_zeros() as usize;
                        hits &= hits - 1;
                        let j = js[l] as usize;
                        if j != i {
                            f(j, Vec2::new(dx[l], dy[l]));
                        }
                    }
                }
            });
        }
        None => {
            view.index.neighbours_at(pos, r, found);
            for nb in found.iter() {
                let j = nb.index as usize;
                if j != i {
                    f(j, view.bounds.offset(pos, view.agents.position(j)));
                }
            }
        }
    }
}

/// Calls `f(d, normal)` for every wall and circle within `r` of `pos`, in index order: `d` runs
/// from the obstacle's closest point to `pos`, `normal` is the direction to use when `d` is zero.
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
    for &w in &b.walls {
        let wall = obstacles.walls()[w as usize];
        let d = pos - wall.closest_point(pos);
        if d.length_squared() <= r_sq {
            let normal = (wall.b - wall.a).perp().normalize_or(Vec2::Y);
            f(d, normal);
        }
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

/// Agent `i`'s request under its pedestrian model, given the behaviours' request.
fn agent(
    view: &SteerView,
    grid: Option<&GridIndex>,
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
    let id = a.ids[i].0;
    let ids = &a.ids;

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
    let cutoff = ped.cutoff();

    let chosen_velocity = match ped.model {
        Model::SocialForce => {
            let sf = &ped.social_force;
            let mut force = Vec2::ZERO;
            for_each_near(view, grid, i, pos, cutoff, &mut b.found, |j, rel| {
                force += sf.pair(
                    -rel,
                    vel,
                    a.velocity(j),
                    radius + a.radius[j],
                    e0,
                    (id, ids[j].0),
                    dt,
                );
            });
            let mut walls = Vec2::ZERO;
            for_each_wall(view, pos, cutoff, b, |d, normal| {
                walls += sf.wall(d, vel, radius, normal, dt);
            });
            let acc = sf.driving(v0, e0, vel) + (force + walls) / sf.mass;
            if !adapter.kinematic {
                return finite_or_zero(truncate(acc, adapter.max_acceleration));
            }
            vel + acc * dt
        }
        Model::Cfsm => {
            let cf = &ped.cfsm;
            let mut dir = e0;
            b.near.clear();
            let near = &mut b.near;
            for_each_near(view, grid, i, pos, cutoff, &mut b.found, |j, rel| {
                let l = radius + a.radius[j];
                near.push((rel, l));
                dir += cf.repulsion(-rel, l, (id, ids[j].0));
            });
            for_each_wall(view, pos, cutoff, b, |d, normal| {
                dir += cf.wall(d, radius, normal);
            });
            let e = dir.normalize_or_zero();
            let spacing = b
                .near
                .iter()
                .filter_map(|&(rel, l)| cf.spacing_to(rel, e, l))
                .fold(f32::INFINITY, f32::min);
            let v = e * cf.speed(spacing, v0);
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
