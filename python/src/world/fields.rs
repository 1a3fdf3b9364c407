//! The grid fields of a `throng.World` from Python: their goals (set, drawn at random, redrawn
//! every few frames) and their walls, cell by cell.
//!
//! Invariant: each method forwards to the `World` method of the same name, which checks its
//! arguments; only the goal cells are read here, and a cell that is no `u32` raises before the
//! world is called.

use pyo3::prelude::*;

use super::PyWorld;
use crate::arrays;
use crate::error::{OrRaise, guarded, invalid};

#[pymethods]
impl PyWorld {
    /// Number of grid fields.
    #[getter]
    fn field_count(&self) -> usize {
        self.world.field_count()
    }

    /// Moves the goals of one channel of a field to the cells `goals` ((m, 2) integer
    /// (x, y) cells); the channel is rebuilt at the start of the next step.
    fn set_field_goals(
        &mut self,
        field: usize,
        channel: usize,
        goals: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guarded(|| {
            let flat = arrays::read_ints("goals", goals)?;
            if !flat.len().is_multiple_of(2) {
                return Err(invalid(
                    "goals",
                    "expected (x, y) cells: an (m, 2) integer array",
                ));
            }
            let cells = flat
                .chunks_exact(2)
                .map(|c| {
                    let cell = |v: i64| {
                        u32::try_from(v).map_err(|_| {
                            invalid(
                                "goals",
                                format!("cell coordinate {v} is negative or too large"),
                            )
                        })
                    };
                    Ok((cell(c[0])?, cell(c[1])?))
                })
                .collect::<PyResult<Vec<_>>>()?;
            self.world
                .set_field_goals(field, channel, &cells)
                .or_raise()
        })
    }

    /// Draws `n` distinct free cells with `seed` as the new goals of one channel.
    fn randomize_field_goals(
        &mut self,
        field: usize,
        channel: usize,
        n: usize,
        seed: u64,
    ) -> PyResult<()> {
        guarded(|| {
            self.world
                .randomize_field_goals(field, channel, n, seed)
                .or_raise()
        })
    }

    /// Re-draws every channel's goals of `field` (`count` cells each) every `every` frames
    /// (0 turns it off).
    fn shuffle_field_goals_every(
        &mut self,
        field: usize,
        every: u64,
        count: usize,
    ) -> PyResult<()> {
        guarded(|| {
            self.world
                .shuffle_field_goals_every(field, every, count)
                .or_raise()
        })
    }

    /// Makes cell (x, y) of `field` a wall (or free ground with `blocked=False`).
    #[pyo3(signature = (field, x, y, blocked=true))]
    fn set_field_blocked(&mut self, field: usize, x: u32, y: u32, blocked: bool) -> PyResult<()> {
        guarded(|| {
            self.world
                .set_field_blocked(field, x, y, blocked)
                .or_raise()
        })
    }
}
