//! Changes to a scenario before it is parsed: values set at dotted paths into its TOML table.
//!
//! An override is a dotted path and the value to put there: `dt`, `world.size`,
//! `groups.0.max_speed`. A path step into a list takes an index, `*` (every element), or a name:
//! the elements whose `name` or `kind` equals it, so
//! `groups.boids.steering.behaviours.alignment.weight` is the weight of every alignment behaviour
//! of the group named `boids`. `__` separates steps too, for keyword arguments
//! (`groups__boids__max_speed=5`). `index` and `reorder_every` stand for `world.index` and
//! `world.reorder_every`.
//!
//! The overridden table is parsed and validated exactly as a file is, so an override can never
//! put into a scenario what a file could not; without overrides the text is parsed as
//! [`Scenario::from_toml`] parses it. A path that leads nowhere is an [`Error::Invalid`] naming
//! it, and nothing is changed.

use crate::error::{Error, Result};

use super::Scenario;

impl Scenario {
    /// Parses a scenario from TOML text after setting each `(path, value)` of `overrides` (see
    /// the module docs), in order.
    ///
    /// ```
    /// use throng::scenario::{Scenario, builtin_text};
    ///
    /// let text = builtin_text("flock").unwrap();
    /// let s = Scenario::from_toml_with(
    ///     text,
    ///     "flock",
    ///     &[("groups.boids.max_speed".into(), toml::Value::Float(3.0))],
    /// )
    /// .unwrap();
    /// assert_eq!(s.groups[0].params.max_speed, 3.0);
    /// ```
    ///
    /// # Errors
    /// What [`Scenario::from_toml`] reports for the text (syntax errors with line and column), an
    /// [`Error::Invalid`] naming the override for a path that leads nowhere, and an
    /// [`Error::Scenario`] naming the overrides for a value the scenario does not accept.
    pub fn from_toml_with(
        text: &str,
        source_name: &str,
        overrides: &[(String, toml::Value)],
    ) -> Result<Scenario> {
        if overrides.is_empty() {
            return Scenario::from_toml(text, source_name);
        }
        let mut table: toml::Table = match text.parse() {
            Ok(t) => t,
            // The parser of files reports syntax errors with line and column.
            Err(_) => return Scenario::from_toml(text, source_name),
        };
        for (key, value) in overrides {
            set_path(&mut table, key, value.clone())?;
        }
        let text = toml::to_string(&table).map_err(|e| Error::Invalid {
            name: "overrides".into(),
            reason: e.to_string(),
        })?;
        // Lines and columns would point into the rewritten text: the error names the overrides
        // instead.
        Scenario::from_toml(&text, source_name).map_err(|e| match e {
            Error::Scenario {
                source_name,
                message,
                ..
            } => Error::Scenario {
                source_name: format!(
                    "{source_name} with overrides {}",
                    overrides
                        .iter()
                        .map(|(k, _)| k.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                location: None,
                message,
            },
            other => other,
        })
    }
}

/// Sets `value` at the dotted `key` of `table` (see the module docs); tables missing on the way
/// are made.
///
/// # Errors
/// [`Error::Invalid`] naming `key` when a step is empty, an index is past the end of a list, no
/// element of a list has the step's name or kind, or a step looks into a value that is neither a
/// table nor a list. The table is then unchanged.
pub fn set_path(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<()> {
    let path = key.replace("__", ".");
    let mut steps: Vec<&str> = path.split('.').collect();
    if let ["index" | "reorder_every"] = steps[..] {
        steps.insert(0, "world");
    }
    if steps.iter().any(|s| s.is_empty()) {
        return Err(bad(key, "an empty step in the path".into()));
    }
    // Set on a copy, so that a path failing half-way leaves the table as it was.
    let mut root = toml::Value::Table(table.clone());
    set(&mut root, &steps, &value, key)?;
    if let toml::Value::Table(t) = root {
        *table = t;
    }
    Ok(())
}

fn bad(key: &str, reason: String) -> Error {
    Error::Invalid {
        name: key.to_string(),
        reason,
    }
}

fn set(node: &mut toml::Value, steps: &[&str], value: &toml::Value, key: &str) -> Result<()> {
    let Some((step, rest)) = steps.split_first() else {
        return Err(bad(key, "an empty path".into()));
    };
    match node {
        toml::Value::Table(t) => {
            if rest.is_empty() {
                t.insert((*step).to_string(), value.clone());
                Ok(())
            } else {
                let child = t
                    .entry((*step).to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()));
                set(child, rest, value, key)
            }
        }
        toml::Value::Array(items) => {
            let chosen: Vec<usize> = if *step == "*" {
                (0..items.len()).collect()
            } else if let Ok(i) = step.parse::<usize>() {
                if i >= items.len() {
                    return Err(bad(
                        key,
                        format!("index {i} is past the end of a list of {}", items.len()),
                    ));
                }
                vec![i]
            } else {
                let named = |v: &toml::Value| {
                    ["name", "kind"]
                        .iter()
                        .any(|k| v.get(k).and_then(toml::Value::as_str) == Some(step))
                };
                let found: Vec<usize> = (0..items.len()).filter(|&i| named(&items[i])).collect();
                if found.is_empty() {
                    return Err(bad(
                        key,
                        format!("no element of the list is named or of kind `{step}`"),
                    ));
                }
                found
            };
            for i in chosen {
                if rest.is_empty() {
                    items[i] = value.clone();
                } else {
                    set(&mut items[i], rest, value, key)?;
                }
            }
            Ok(())
        }
        _ => Err(bad(
            key,
            format!("`{step}` cannot be looked up in a value that is not a table or a list"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::{builtin, builtin_text};

    fn flock(overrides: &[(&str, toml::Value)]) -> Result<Scenario> {
        let overrides: Vec<(String, toml::Value)> = overrides
            .iter()
            .map(|(k, v)| ((*k).to_string(), v.clone()))
            .collect();
        Scenario::from_toml_with(builtin_text("flock").unwrap(), "flock", &overrides)
    }

    #[test]
    fn overrides_reach_lists_by_name_kind_index_and_star() {
        let s = flock(&[
            (
                "groups.boids.steering.behaviours.alignment.weight",
                toml::Value::Float(2.5),
            ),
            ("groups__0__max_speed", toml::Value::Float(3.0)),
            ("groups.*.radius", toml::Value::Float(0.25)),
            ("index", toml::Value::String("kdtree".into())),
            ("dt", toml::Value::Float(0.05)),
        ])
        .unwrap();
        let g = &s.groups[0].params;
        assert_eq!(g.steering.behaviours[1].weight, 2.5);
        assert_eq!(g.steering.behaviours[0].weight, 1.5);
        assert_eq!((g.max_speed, g.radius), (3.0, 0.25));
        assert_eq!(s.world.index, crate::IndexKind::KdTree);
        assert_eq!(s.dt, 0.05);
    }

    #[test]
    fn overrides_that_lead_nowhere_name_the_key_and_change_nothing() {
        for key in [
            "groups.nobody.max_speed",
            "groups.5.max_speed",
            "dt.x",
            "groups..x",
            "groups.*.steering.behaviours.nobody.weight",
        ] {
            let e = flock(&[(key, toml::Value::Float(1.0))]).unwrap_err();
            assert!(e.to_string().contains(key), "{key}: {e}");
            let mut table: toml::Table = builtin_text("flock").unwrap().parse().unwrap();
            let before = table.clone();
            assert!(set_path(&mut table, key, toml::Value::Float(1.0)).is_err());
            assert_eq!(table, before, "{key}");
        }
        let e = flock(&[("groups.0.max_sped", toml::Value::Float(1.0))]).unwrap_err();
        assert!(e.to_string().contains("max_sped"), "{e}");
        let e = flock(&[("dt", toml::Value::Float(-1.0))]).unwrap_err();
        assert!(e.to_string().contains("with overrides dt"), "{e}");
    }

    #[test]
    fn no_overrides_parse_as_files_do() {
        assert_eq!(flock(&[]).unwrap(), builtin("flock").unwrap());
    }
}
