//! The Vicsek model: without noise a flock of random headings orders itself, with full noise it
//! stays as disordered as independent headings, speed is constant, and the result does not
//! depend on the thread count or the neighbour backend.

use throng::prelude::*;
use throng::{IndexKind, scenario};

/// A Vicsek world of `n` agents at 2 per unit area with the given noise.
fn world(n: usize, noise: f32, seed: u64) -> World {
    let text = scenario::builtin("vicsek").unwrap();
    let mut s = text.with_agents(n).unwrap();
    s.seed = seed;
    for w in &mut s.groups[0].params.steering.behaviours {
        if let Behaviour::Vicsek { noise: eta, .. } = &mut w.behaviour {
            *eta = noise;
        }
    }
    s.build().unwrap()
}

fn run(w: &mut World, steps: usize) {
    for _ in 0..steps {
        w.step(1.0).unwrap();
    }
}

#[test]
fn without_noise_random_headings_align() {
    let mut w = world(200, 0.0, 3);
    assert!(w.polarisation() < 0.2, "random start {}", w.polarisation());
    run(&mut w, 1000);
    assert!(
        w.polarisation() >= 0.99,
        "polarisation {}",
        w.polarisation()
    );
}

#[test]
fn with_full_noise_headings_stay_independent() {
    // Independent uniform headings: E|mean unit vector|^2 = 1 / N, so the polarisation is about
    // sqrt(pi / 4N) ~ 0.028 for N = 1000; averaged over 50 frames it stays within a few times that.
    let n = 1000;
    let mut w = world(n, std::f32::consts::TAU, 5);
    run(&mut w, 20);
    let mut sum = 0.0;
    for _ in 0..50 {
        run(&mut w, 1);
        sum += w.polarisation();
    }
    let mean = sum / 50.0;
    let independent = (std::f32::consts::PI / (4.0 * n as f32)).sqrt();
    assert!(
        mean < 3.0 * independent,
        "mean polarisation {mean} vs {independent} for independent headings"
    );
}

#[test]
fn speed_stays_constant() {
    let mut w = world(500, 1.0, 1);
    run(&mut w, 30);
    let a = w.agents();
    for i in 0..a.len() {
        let v = a.velocity(i).length();
        assert!((v - 0.3).abs() < 1e-5, "agent {i} speed {v}");
    }
}

#[test]
fn threads_and_backends_give_the_same_bits() {
    let snapshot = |threads: usize, kind: IndexKind| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut w = world(2000, 0.5, 11);
            w.set_index(kind);
            run(&mut w, 25);
            let mut v: Vec<_> = (0..w.len())
                .map(|i| {
                    let a = w.agents();
                    (a.id(i), a.pos_x()[i].to_bits(), a.vel_y()[i].to_bits())
                })
                .collect();
            v.sort();
            v
        })
    };
    let one = snapshot(1, IndexKind::Grid);
    assert!(one == snapshot(2, IndexKind::Grid), "1 vs 2 threads");
    assert!(one == snapshot(4, IndexKind::Grid), "1 vs 4 threads");
    // Without the grid's reordering, storage order is the same on every backend, and the
    // scalar traversal lists neighbours in ascending storage order on each.
    let kd = snapshot(2, IndexKind::KdTree);
    assert!(
        kd == snapshot(1, IndexKind::Brute),
        "k-d tree vs brute force"
    );
}

#[test]
fn the_model_is_kinematic_and_its_numbers_are_checked() {
    let vicsek = |radius, noise| SteeringProfile::single(Behaviour::Vicsek { radius, noise });
    let dynamic = Profile::dynamic(vicsek(1.0, 0.5));
    assert!(matches!(
        World::builder().group(dynamic).build(),
        Err(Error::Invalid { .. })
    ));
    for (r, eta) in [
        (0.0, 0.5),
        (-1.0, 0.5),
        (1.0, -0.1),
        (1.0, 7.0),
        (f32::NAN, 0.1),
    ] {
        let g = Profile::kinematic(vicsek(r, eta));
        assert!(World::builder().group(g).build().is_err(), "{r} {eta}");
    }
}

/// Whether the steering requests of the worlds `make` builds, after 5 steps, agree within `tol`
/// on the grid (cell batches) and on the k-d tree (the per-agent scalar traversal); returns how
/// many requests are nonzero.
fn batch_agrees_with_scalar(make: impl Fn() -> World, tol: f32) -> usize {
    let outputs = |kind: IndexKind| {
        let mut w = make();
        run(&mut w, 5);
        w.set_index(kind);
        let mut out = w.steering_outputs(1.0).unwrap();
        out.sort_by_key(|(id, _)| *id);
        out
    };
    let (grid, kd) = (outputs(IndexKind::Grid), outputs(IndexKind::KdTree));
    assert_eq!(grid.len(), kd.len());
    for ((id, g), (_, k)) in grid.iter().zip(&kd) {
        assert!(
            (g.linear - k.linear).length() <= tol,
            "{id}: {:?} vs {:?}",
            g.linear,
            k.linear
        );
    }
    grid.iter().filter(|(_, g)| g.linear.length() > 0.0).count()
}

#[test]
fn the_cell_batch_equals_the_scalar_reference_to_rounding() {
    // The headings sum in another order, so the requests agree to rounding.
    let nonzero = batch_agrees_with_scalar(|| world(3000, 0.7, 13), 1e-5);
    assert_eq!(nonzero, 3000);
}

#[test]
fn beside_a_flock_the_cell_batch_equals_the_scalar_reference_to_rounding() {
    // A Vicsek group and a flock in one world: the cell buffers hold velocities and headings,
    // the Vicsek sums read the headings, the flock's sums the velocities.
    let text = r#"
name = "mixed"
seed = 5
dt = 1.0
[world]
kind = "torus"
size = [40, 40]
[[groups]]
name = "particles"
count = 1500
spawn = { kind = "uniform" }
model = "kinematic"
initial_speed = 0.3
max_speed = 0.3
steering = { behaviours = [{ kind = "vicsek", radius = 1.5, noise = 0.8 }] }
[[groups]]
name = "boids"
count = 1500
spawn = { kind = "uniform" }
initial_speed = 0.5
max_speed = 0.5
max_acceleration = 1
steering = { behaviours = [
  { kind = "separation", radius = 1, weight = 1.5 },
  { kind = "alignment", radius = 2, weight = 1.0 },
  { kind = "cohesion", radius = 2, weight = 0.8 },
] }
"#;
    let make = || {
        scenario::Scenario::from_toml(text, "mixed")
            .unwrap()
            .build()
            .unwrap()
    };
    let nonzero = batch_agrees_with_scalar(make, 1e-4);
    assert!(nonzero > 2500, "{nonzero}");
}
