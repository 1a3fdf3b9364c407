//! Every built-in scenario, mutated (numbers to NaN, infinities, negative and huge values; keys
//! dropped, duplicated and retyped; the text truncated), either is refused with a typed error
//! or builds a world whose first steps keep every agent buffer finite: never a panic, a hang or
//! an abort. The files of `tests/data/` (the inputs that found earlier bugs) are held to the
//! same rule.
//!
//! The scenarios are first shrunk (groups to at most 20 agents, generated maps to at most
//! 64 x 64 cells) and worlds are built within 256 MiB, so a case takes milliseconds.

use proptest::prelude::*;
use throng::scenario::{BUILTIN, Scenario};

const MEMORY: u64 = 256 << 20;

/// The built-in scenario `k`, shrunk, as a TOML table.
fn shrunk(k: usize) -> toml::Table {
    let mut t: toml::Table = toml::from_str(BUILTIN[k].1).unwrap();
    if let Some(toml::Value::Array(groups)) = t.get_mut("groups") {
        for g in groups {
            if let Some(toml::Value::Integer(c)) = g.get_mut("count") {
                *c = (*c).min(20);
            }
        }
    }
    if let Some(toml::Value::Table(field)) = t.get_mut("field")
        && let Some(toml::Value::Table(map)) = field.get_mut("map")
    {
        for kind in ["caves", "tunnels"] {
            if let Some(toml::Value::Table(m)) = map.get_mut(kind) {
                for side in ["width", "height"] {
                    if let Some(toml::Value::Integer(v)) = m.get_mut(side) {
                        *v = (*v).min(64);
                    }
                }
            }
        }
    }
    t
}

/// The paths (keys and array indices) of every value in `v`, depth first.
fn paths(v: &toml::Value, at: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                at.push(k.clone());
                out.push(at.clone());
                paths(x, at, out);
                at.pop();
            }
        }
        toml::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                at.push(i.to_string());
                out.push(at.clone());
                paths(x, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn get_mut<'a>(v: &'a mut toml::Value, path: &[String]) -> Option<&'a mut toml::Value> {
    path.iter().try_fold(v, |v, k| match v {
        toml::Value::Table(t) => t.get_mut(k),
        toml::Value::Array(a) => a.get_mut(k.parse::<usize>().ok()?),
        _ => None,
    })
}

/// What a mutation does to the chosen value.
#[derive(Clone, Copy, Debug)]
enum Mutation {
    /// Numbers become this (other values are left alone).
    Number(f64),
    /// Integers become this.
    Integer(i64),
    /// The key (or array entry) is removed.
    Drop,
    /// The value becomes a string, a table becomes a number, and so on.
    Retype,
    /// The key's line appears twice in the text.
    Duplicate,
    /// The text ends at this fraction of its length.
    Truncate(f64),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        prop::sample::select(vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -1.0,
            -1e30,
            0.0,
            1e-45,
            1e18,
            1e30,
            3.4e38,
        ])
        .prop_map(Mutation::Number),
        prop::sample::select(vec![i64::MAX, i64::MIN, -1, 0, 1 << 40, 100_000_000])
            .prop_map(Mutation::Integer),
        Just(Mutation::Drop),
        Just(Mutation::Retype),
        Just(Mutation::Duplicate),
        (0.0..1.0f64).prop_map(Mutation::Truncate),
    ]
}

/// The mutated scenario text.
fn mutate(k: usize, pick: usize, m: Mutation) -> String {
    let mut root = toml::Value::Table(shrunk(k));
    let mut all = Vec::new();
    paths(&root, &mut Vec::new(), &mut all);
    let path = &all[pick % all.len()];
    match m {
        Mutation::Number(x) => {
            if let Some(v) = get_mut(&mut root, path)
                && matches!(v, toml::Value::Float(_) | toml::Value::Integer(_))
            {
                *v = toml::Value::Float(x);
            }
        }
        Mutation::Integer(i) => {
            if let Some(v) = get_mut(&mut root, path)
                && matches!(v, toml::Value::Float(_) | toml::Value::Integer(_))
            {
                *v = toml::Value::Integer(i);
            }
        }
        Mutation::Drop => {
            let (last, parent) = path.split_last().unwrap();
            match get_mut(&mut root, parent) {
                Some(toml::Value::Table(t)) => {
                    t.remove(last);
                }
                Some(toml::Value::Array(a)) => {
                    a.remove(last.parse().unwrap());
                }
                _ => {}
            }
        }
        Mutation::Retype => {
            if let Some(v) = get_mut(&mut root, path) {
                *v = match v {
                    toml::Value::String(_) => toml::Value::Integer(7),
                    toml::Value::Table(_) => toml::Value::Float(2.5),
                    toml::Value::Array(_) => toml::Value::Boolean(true),
                    _ => toml::Value::String("x\u{1b}[2J".into()),
                };
            }
        }
        Mutation::Duplicate | Mutation::Truncate(_) => {}
    }
    let text = toml::to_string(&root).unwrap();
    match m {
        Mutation::Duplicate => {
            let lines: Vec<&str> = text.lines().collect();
            let keyed: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].contains(" = "))
                .collect();
            let i = keyed[pick % keyed.len()];
            let mut out: Vec<&str> = lines[..=i].to_vec();
            out.extend_from_slice(&lines[i..]);
            out.join("\n")
        }
        Mutation::Truncate(f) => {
            let mut cut = (text.len() as f64 * f) as usize;
            while !text.is_char_boundary(cut) {
                cut -= 1;
            }
            text[..cut].to_string()
        }
        _ => text,
    }
}

/// A typed error, or a world whose first steps keep every buffer finite.
fn holds(text: &str, name: &str) -> Result<(), String> {
    holds_built(text, name).map(|_| ())
}

/// As [`holds`]; `Ok(true)` when a world was built and stepped.
fn holds_built(text: &str, name: &str) -> Result<bool, String> {
    let s = match Scenario::from_toml(text, name) {
        Ok(s) => s,
        Err(e) => return check_message(&e).map(|()| false),
    };
    let mut world = match s.build_within(Some(MEMORY)) {
        Ok(w) => w,
        Err(e) => return check_message(&e).map(|()| false),
    };
    for step in 0..3 {
        if let Err(e) = world.step(s.dt) {
            return check_message(&e).map(|()| false);
        }
        let a = world.agents();
        for (buf, v) in [
            ("pos_x", a.pos_x()),
            ("pos_y", a.pos_y()),
            ("vel_x", a.vel_x()),
            ("vel_y", a.vel_y()),
            ("orientation", a.orientations()),
            ("rotation", a.rotations()),
        ] {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(format!("step {step}: {buf}[{i}] = {}", v[i]));
            }
        }
    }
    Ok(true)
}

fn check_message(e: &throng::Error) -> Result<(), String> {
    let text = e.to_string();
    if text.chars().any(char::is_control) {
        return Err(format!("control characters in the error {text:?}"));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn mutated_builtins_are_refused_or_stay_finite(
        k in 0..BUILTIN.len(),
        pick in any::<usize>(),
        m in mutation(),
    ) {
        let text = mutate(k, pick, m);
        let r = holds(&text, BUILTIN[k].0);
        prop_assert!(r.is_ok(), "{} {m:?}: {}\n{text}", BUILTIN[k].0, r.unwrap_err());
    }
}

#[test]
fn a_sweep_of_number_mutations_builds_worlds_and_stays_finite() {
    // Every value to each of a few numbers, scenario by scenario: enough of them still build
    // that the stepping is exercised, not only the parser.
    let (mut cases, mut built) = (0, 0);
    for (k, (name, _)) in BUILTIN.iter().enumerate() {
        let mut all = Vec::new();
        paths(&toml::Value::Table(shrunk(k)), &mut Vec::new(), &mut all);
        for (pick, path) in all.iter().enumerate() {
            for m in [
                Mutation::Number(-1.0),
                Mutation::Number(1e18),
                Mutation::Number(f64::NAN),
                Mutation::Number(0.0),
            ] {
                let text = mutate(k, pick, m);
                cases += 1;
                match holds_built(&text, name) {
                    Ok(b) => built += usize::from(b),
                    Err(e) => panic!("{name} {path:?} {m:?}: {e}\n{text}"),
                }
            }
        }
    }
    assert!(built * 5 >= cases, "{built} of {cases} cases built a world");
}

#[test]
fn every_builtin_shrunk_and_unmutated_builds_and_stays_finite() {
    for (k, (name, _)) in BUILTIN.iter().enumerate() {
        let text = toml::to_string(&shrunk(k)).unwrap();
        Scenario::from_toml(&text, name)
            .and_then(|s| s.build_within(Some(MEMORY)))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        holds(&text, name).unwrap();
    }
}

#[test]
fn the_regression_inputs_are_refused_or_stay_finite() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let text = std::fs::read_to_string(&path).unwrap();
            holds(&text, &path.display().to_string())
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            seen += 1;
        }
    }
    assert!(seen >= 5, "{seen} regression files");
}
