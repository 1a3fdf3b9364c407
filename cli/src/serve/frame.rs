//! What `throng serve` sends: the binary frame of agent positions the page draws, and the JSON
//! of the world's geometry (`GET /world`).
//!
//! Frame layout (little-endian; docs/SERVE.md is the reference), [`HEADER_LEN`] bytes of header
//! and then structure-of-arrays agent data in storage order:
//!
//! ```text
//!  0  magic "THRF"            4  u16 version (1)        6  u16 flags (bit 0: paused)
//!  8  u64 frame              16  f64 simulated time    24  u32 agents N
//! 28  u32 world version      32  f32 origin x, y       40  f32 quantum x, y
//! 48  f32 ms per step        52  f32 x 6 phase ms      76  f32 agent-steps per second
//! 80  f32 speed scale        84  u16 steps per frame   86  u16 gravity points G
//! 88  N x u16 x, N x u16 y, N x u8 heading, N x u8 speed, N x u8 group,
//!     then G x (f32 x, f32 y, f32 strength, f32 radius)
//! ```
//!
//! Invariants: a position decodes as `origin + q * quantum` within half a quantum of the true
//! one (the box is the world's rectangle, or the agents' extent in an open world); heading is
//! the orientation in 256ths of a turn; speed is `|v| / speed scale` in 255ths, clamped.

use serde_json::{Value, json};
use throng::prelude::Vec2;
use throng::{Bounds, GoalChannels, World};

/// The frame's magic bytes.
pub const MAGIC: &[u8; 4] = b"THRF";
/// The frame layout's version.
pub const VERSION: u16 = 1;
/// Bytes before the agent arrays.
pub const HEADER_LEN: usize = 88;
/// Flag bit: the simulation is paused.
pub const FLAG_PAUSED: u16 = 1;
/// The heat map's colours from a goal (first) to the farthest reachable cell (last), at equal
/// steps: the ramp of the PNG and GIF pictures (`throng::render::Palette`), bright at the goals
/// and dark far from them, so that the page and `--render` read the same way.
pub const HEAT_RAMP: [[u8; 3]; 5] = [
    [175, 160, 40],
    [70, 140, 70],
    [24, 100, 100],
    [38, 56, 100],
    [40, 10, 56],
];
/// Longest side, in cells, of the field layer in `GET /world` (larger grids are sampled down).
const MAX_LAYER_SIDE: u32 = 1024;

/// What the header says besides the world's own state.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameInfo {
    /// Whether the simulation is paused.
    pub paused: bool,
    /// The geometry version the page should have (it refetches `/world` when this changes).
    pub world_version: u32,
    /// Mean time of the steps since the last frame, milliseconds.
    pub step_ms: f64,
    /// Mean time of each phase over those steps, in `PhaseTimes::NAMES` order (the six of the
    /// step; a served world measures nothing).
    pub phases_ms: [f64; 6],
    /// Agent-steps per second of wall time over the last second.
    pub agent_steps_per_sec: f64,
    /// Steps between frames.
    pub steps_per_frame: u32,
}

/// The quantisation box: the world's rectangle, or the agents' extent (at least one unit wide)
/// in an open world. Returns `(origin, quantum)`.
fn quantisation(world: &World) -> (Vec2, Vec2) {
    let (lo, size) = match world.bounds().size() {
        Some(size) => (Vec2::ZERO, size),
        None => {
            let a = world.agents();
            let mut lo = Vec2::splat(f32::INFINITY);
            let mut hi = Vec2::splat(f32::NEG_INFINITY);
            for i in 0..a.len() {
                lo = lo.min(a.position(i));
                hi = hi.max(a.position(i));
            }
            if a.is_empty() {
                (Vec2::ZERO, Vec2::ONE)
            } else {
                (lo, (hi - lo).max(Vec2::ONE))
            }
        }
    };
    (lo, size / f32::from(u16::MAX))
}

/// The largest maximum speed of the world's groups (1 when none is positive): the speed byte's
/// full scale.
fn speed_scale(world: &World) -> f32 {
    let v = world
        .groups()
        .iter()
        .map(|g| g.max_speed)
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max);
    if v > 0.0 { v } else { 1.0 }
}

/// Encodes the world's current frame into `out` (cleared first).
pub fn encode(world: &World, info: &FrameInfo, out: &mut Vec<u8>) {
    let a = world.agents();
    let n = a.len();
    let (origin, quantum) = quantisation(world);
    let vmax = speed_scale(world);
    let gravity = world.gravity().points();
    out.clear();
    out.reserve(HEADER_LEN + 7 * n + 16 * gravity.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    let flags = if info.paused { FLAG_PAUSED } else { 0 };
    out.extend_from_slice(&flags.to_le_bytes());
    out.extend_from_slice(&world.frame().to_le_bytes());
    out.extend_from_slice(&world.time().to_le_bytes());
    out.extend_from_slice(&(n as u32).to_le_bytes());
    out.extend_from_slice(&info.world_version.to_le_bytes());
    for v in [
        origin.x,
        origin.y,
        quantum.x,
        quantum.y,
        info.step_ms as f32,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in info.phases_ms {
        out.extend_from_slice(&(v as f32).to_le_bytes());
    }
    out.extend_from_slice(&(info.agent_steps_per_sec as f32).to_le_bytes());
    out.extend_from_slice(&vmax.to_le_bytes());
    let spf = info.steps_per_frame.min(u32::from(u16::MAX)) as u16;
    out.extend_from_slice(&spf.to_le_bytes());
    let g = gravity.len().min(usize::from(u16::MAX));
    out.extend_from_slice(&(g as u16).to_le_bytes());
    debug_assert_eq!(out.len(), HEADER_LEN);
    out.resize(HEADER_LEN + 7 * n + 16 * g, 0);
    let (xs, rest) = out[HEADER_LEN..].split_at_mut(2 * n);
    let (ys, rest) = rest.split_at_mut(2 * n);
    let (headings, rest) = rest.split_at_mut(n);
    let (speeds, rest) = rest.split_at_mut(n);
    let (groups, points) = rest.split_at_mut(n);
    let inv = Vec2::ONE / quantum;
    quantise(xs, a.pos_x(), origin.x, inv.x);
    quantise(ys, a.pos_y(), origin.y, inv.y);
    let turn = 256.0 / std::f32::consts::TAU;
    for (d, &h) in headings.iter_mut().zip(a.orientations()) {
        *d = (round_to_int(h * turn) & 255) as u8;
    }
    let speed = 255.0 / vmax;
    for (d, (&vx, &vy)) in speeds.iter_mut().zip(a.vel_x().iter().zip(a.vel_y())) {
        // `as` saturates: speeds past the scale are 255.
        *d = ((vx * vx + vy * vy).sqrt() * speed + 0.5) as u8;
    }
    for (d, &g) in groups.iter_mut().zip(a.groups()) {
        *d = g.min(255) as u8;
    }
    for (d, p) in points.chunks_exact_mut(16).zip(&gravity[..g]) {
        for (k, v) in [p.position.x, p.position.y, p.strength, p.radius]
            .into_iter()
            .enumerate()
        {
            d[4 * k..4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
}

/// `v` rounded to the nearest integer (halves away from zero) without `f32::round`, which the
/// baseline x86-64 target compiles to a library call, per value, in the frame's hottest loop
/// (docs/PERFORMANCE.md, "Tuning constants").
#[inline]
fn round_to_int(v: f32) -> i32 {
    let t = v as i32;
    let r = v - t as f32;
    t + i32::from(r >= 0.5) - i32::from(r <= -0.5)
}

/// Writes `round((v - origin) * inv)`, clamped to `u16`, little-endian, for each value.
fn quantise(out: &mut [u8], values: &[f32], origin: f32, inv: f32) {
    for (d, &v) in out.chunks_exact_mut(2).zip(values) {
        // `as` truncates towards zero and saturates: this rounds and clamps to 0..=65535.
        let q = ((v - origin) * inv + 0.5) as u16;
        d.copy_from_slice(&q.to_le_bytes());
    }
}

/// The bytes as standard base64 (with padding).
fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let v = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                s.push(char::from(ABC[(v >> (18 - 6 * k) & 63) as usize]));
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A field's layer for the page: its grid sampled down to at most [`MAX_LAYER_SIDE`] cells a
/// side, one byte per sample: 255 a wall, 254 unreachable from channel 0's goals (or not yet
/// built), otherwise the BFS step count scaled to 0..=253 (0 at a goal).
fn field_layer(channels: &GoalChannels) -> Value {
    let grid = channels.grid();
    let (w, h) = (grid.width(), grid.height());
    let k = w.max(h).div_ceil(MAX_LAYER_SIDE).max(1);
    let (lw, lh) = (w.div_ceil(k), h.div_ceil(k));
    let potential = channels.field(0);
    let max_steps = potential.map_or(0, |p| {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter_map(|(x, y)| p.steps(x, y))
            .max()
            .unwrap_or(0)
    });
    let mut bytes = Vec::with_capacity((lw * lh) as usize);
    for ly in 0..lh {
        for lx in 0..lw {
            let (x, y) = (lx * k, ly * k);
            let value = if !grid.is_free(x, y) {
                255
            } else {
                match potential.and_then(|p| p.steps(x, y)) {
                    Some(s) if max_steps > 0 => {
                        (u64::from(s) * 253 / u64::from(max_steps)).min(253) as u8
                    }
                    Some(_) => 0,
                    None => 254,
                }
            };
            bytes.push(value);
        }
    }
    let goals: Vec<Value> = (0..channels.len())
        .map(|c| {
            let cells = channels.goals(c).unwrap_or(&[]);
            Value::Array(
                cells
                    .iter()
                    .map(|&(x, y)| {
                        let p = grid.cell_center(x, y);
                        json!([x, y, p.x, p.y])
                    })
                    .collect(),
            )
        })
        .collect();
    json!({
        "width": w,
        "height": h,
        "cell_size": grid.cell_size(),
        "origin": [grid.origin().x, grid.origin().y],
        "layer": { "width": lw, "height": lh, "step": k, "cells": base64(&bytes) },
        "goals": goals,
    })
}

/// The click modes of the page that change what happens in `world`: `goal` with a field,
/// `gravity` when some group has an anti-gravity behaviour (nothing else feels gravity points),
/// and `wall` and `circle` always (no agent crosses an obstacle).
fn click_modes(world: &World) -> Vec<&'static str> {
    let feels_gravity = world.groups().iter().any(|g| {
        g.steering
            .behaviours
            .iter()
            .any(|w| w.behaviour.name().starts_with("anti_gravity"))
    });
    let mut modes = Vec::with_capacity(4);
    if world.field_count() > 0 {
        modes.push("goal");
    }
    if feels_gravity {
        modes.push("gravity");
    }
    modes.extend(["wall", "circle"]);
    modes
}

/// The world's geometry as `GET /world` serves it.
pub fn world_json(world: &World, version: u32) -> Value {
    let bounds = match world.bounds() {
        Bounds::Open => json!({ "kind": "open" }),
        Bounds::Bounded { size } => json!({ "kind": "bounded", "size": [size.x, size.y] }),
        Bounds::Torus { size } => json!({ "kind": "torus", "size": [size.x, size.y] }),
    };
    let o = world.obstacles();
    let circles: Vec<Value> = o
        .circles()
        .iter()
        .map(|c| json!([c.center.x, c.center.y, c.radius]))
        .collect();
    let walls: Vec<Value> = o
        .walls()
        .iter()
        .map(|w| json!([w.a.x, w.a.y, w.b.x, w.b.y]))
        .collect();
    let paths: Vec<Value> = world
        .paths()
        .iter()
        .map(|p| {
            let points: Vec<Value> = p.points().iter().map(|q| json!([q.x, q.y])).collect();
            json!({ "points": points, "radius": p.radius(), "looped": p.is_looped() })
        })
        .collect();
    let groups: Vec<Value> = world
        .groups()
        .iter()
        .map(|g| json!({ "name": g.name, "radius": g.radius, "max_speed": g.max_speed }))
        .collect();
    // What the page fits on load: the world's rectangle, or in an open world everything in it.
    let (lo, hi) = world.extent();
    let fields: Vec<Value> = (0..world.field_count())
        .filter_map(|f| world.field(f))
        .map(field_layer)
        .collect();
    json!({
        "version": version,
        "bounds": bounds,
        "circles": circles,
        "walls": walls,
        "paths": paths,
        "groups": groups,
        "fields": fields,
        "heat_ramp": HEAT_RAMP,
        "extent": [lo.x, lo.y, hi.x, hi.y],
        "modes": click_modes(world),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_the_standard_alphabet_and_padding() {
        assert_eq!(base64(b""), "");
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
        assert_eq!(base64(&[255, 254, 0]), "//4A");
    }

    #[test]
    fn rounding_without_the_library_call_matches_round() {
        for v in [
            0.0f32, 0.49, 0.5, 0.51, 1.5, -0.49, -0.5, -0.51, -1.5, 255.7, -255.7, 1e6,
        ] {
            assert_eq!(round_to_int(v), v.round() as i32, "{v}");
        }
        let mut out = [0u8; 8];
        quantise(&mut out, &[-3.0, 0.26, 0.24, 1e9], 0.0, 2.0);
        let q: Vec<u16> = out
            .chunks(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect();
        assert_eq!(q, [0, 1, 0, u16::MAX]);
    }
}
