//! The groups of a `throng.World` from Python: a group's profile as a dict with the keys of a
//! scenario file's group table, replaced or added from one.
//!
//! Invariant: a profile from Python is read with the schema of a scenario file's group table
//! and checked as the world checks any profile, so unknown keys and bad values raise.

use pyo3::prelude::*;
use throng::{Error, Profile};

use super::PyWorld;
use crate::convert;
use crate::error::{OrRaise, guarded, raise};

#[pymethods]
impl PyWorld {
    /// Group `group`'s profile as a dict with the keys of a scenario file's group table
    /// (`model`, `max_speed`, `steering`, ...).
    fn group_params<'py>(&self, py: Python<'py>, group: usize) -> PyResult<Bound<'py, PyAny>> {
        let g = self.world.groups().get(group).ok_or_else(|| {
            raise(&Error::UnknownGroup {
                group,
                count: self.world.groups().len(),
            })
        })?;
        convert::serialize_to_py(py, g, true)
    }

    /// Replaces group `group`'s profile with `params`, a dict with the keys of a scenario
    /// file's group table (missing keys take their defaults). Agents without their own maximum
    /// speed or radius take the new ones.
    fn set_group_params(&mut self, group: usize, params: &Bound<'_, PyAny>) -> PyResult<()> {
        guarded(|| {
            let p: Profile = convert::deserialize_from_py("params", params)?;
            self.world.set_group_params(group, p).or_raise()
        })
    }

    /// Adds a group with the profile `params` (as for `set_group_params`); returns its index.
    fn add_group(&mut self, params: &Bound<'_, PyAny>) -> PyResult<usize> {
        guarded(|| {
            let p: Profile = convert::deserialize_from_py("params", params)?;
            // The world is built: a group the profile names must exist now too (the Rust
            // `add_group` lets one come later, and a missing one made every later step fail).
            self.world.check_group_params(&p).or_raise()?;
            self.world.add_group(p).or_raise()
        })
    }
}
