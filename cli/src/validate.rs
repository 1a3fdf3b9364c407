//! `throng validate`: runs the validation suite and prints each criterion, the measured value
//! and the verdict, or one JSON object with `--json`.

use std::time::Instant;

use clap::Args;
use throng::validate::{self, CaseReport, Options, Size};
use throng::{Error, Result};

use crate::files::say;

/// Options of `throng validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// Cases to run, by id (default: all; `--list` names them).
    pub cases: Vec<String>,
    /// Smaller crowds and fewer sample points where the criteria allow (each case says what).
    #[arg(long)]
    pub quick: bool,
    /// Print one JSON object (cases, checks, measured series) instead of the table.
    #[arg(long)]
    pub json: bool,
    /// List the cases and what each checks, and exit.
    #[arg(long)]
    pub list: bool,
    /// Worker threads (default: all cores); any count gives the same results.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Pedestrian model of every group: social_force (also sfm) or cfsm (default: the
    /// scenarios', the default model).
    #[arg(long, value_name = "MODEL", value_parser = clap::builder::PossibleValuesParser::new(throng::ped::Model::names()))]
    pub pedestrian_model: Option<String>,
    /// Added to every scenario's seed (default 0: the files' seeds).
    #[arg(long, default_value_t = 0)]
    pub seed_offset: u64,
    /// A pedestrian parameter for every pedestrian group, as a dotted key inside the
    /// `pedestrian` table and a TOML value: `cfsm.time_gap=0.8`, `social_force.tau=0.4`
    /// (repeatable; applied after `--pedestrian-model`).
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
}

/// `key=value` as a key and a TOML value (a number, a boolean or a quoted string; a bare word
/// is taken as a string).
fn parse_param(text: &str) -> Result<(String, toml::Value)> {
    let bad = |reason: &str| Error::Invalid {
        name: "--param".into(),
        reason: format!("{reason} in `{text}` (expected KEY=VALUE, e.g. cfsm.time_gap=0.8)"),
    };
    let (key, value) = text.split_once('=').ok_or_else(|| bad("no `=`"))?;
    let key = key.trim();
    if key.is_empty() {
        return Err(bad("an empty key"));
    }
    let value = value.trim();
    let parsed = format!("v = {value}")
        .parse::<toml::Table>()
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(value.to_string()));
    if let toml::Value::Float(f) = parsed
        && !f.is_finite()
    {
        return Err(bad("a value that is not finite"));
    }
    Ok((key.to_string(), parsed))
}

/// Runs the cases and reports; an error when a check failed.
pub fn run(args: &ValidateArgs, pool: &rayon::ThreadPool) -> Result<()> {
    if args.list {
        for c in validate::CASES {
            say(&format!(
                "{:<11} {}\n            {}",
                c.id, c.title, c.about
            ))?;
        }
        return Ok(());
    }
    let cases = if args.cases.is_empty() {
        validate::CASES.iter().collect::<Vec<_>>()
    } else {
        args.cases
            .iter()
            .map(|id| validate::case(id))
            .collect::<Result<Vec<_>>>()?
    };
    let model = match &args.pedestrian_model {
        Some(name) => Some(
            throng::ped::Model::parse(name).ok_or_else(|| Error::Invalid {
                name: "--pedestrian-model".into(),
                reason: format!("unknown model {name}"),
            })?,
        ),
        None => None,
    };
    let options = Options {
        size: if args.quick { Size::Quick } else { Size::Full },
        model,
        seed_offset: args.seed_offset,
        params: args
            .params
            .iter()
            .map(|p| parse_param(p))
            .collect::<Result<_>>()?,
    };
    let start = Instant::now();
    let mut reports = Vec::new();
    for case in cases {
        let t = Instant::now();
        let report = pool.install(|| validate::run_case(case, &options))?;
        if !args.json {
            print_case(&report, t.elapsed().as_secs_f64())?;
        }
        reports.push(report);
    }
    let pass = reports.iter().all(|r| r.pass);
    let failed: Vec<String> = reports
        .iter()
        .flat_map(|r| {
            r.checks
                .iter()
                .filter(|c| !c.pass)
                .map(move |c| format!("{}: {}", r.id, c.name))
        })
        .collect();
    if args.json {
        let doc = serde_json::json!({
            "pass": pass,
            "size": options.size,
            "model": model.map_or("scenario", |m| m.name()),
            "seconds": start.elapsed().as_secs_f64(),
            "cases": reports,
        });
        let text = serde_json::to_string(&doc).map_err(|e| Error::Invalid {
            name: "validate --json".into(),
            reason: e.to_string(),
        })?;
        say(&text)?;
    } else {
        let checks: usize = reports.iter().map(|r| r.checks.len()).sum();
        say(&format!(
            "{} of {checks} checks passed in {} cases ({:.1} s)",
            checks - failed.len(),
            reports.len(),
            start.elapsed().as_secs_f64()
        ))?;
    }
    if pass {
        Ok(())
    } else {
        Err(Error::Invalid {
            name: "validation".into(),
            reason: format!("{} check(s) failed: {}", failed.len(), failed.join("; ")),
        })
    }
}

fn print_case(r: &CaseReport, seconds: f64) -> Result<()> {
    say(&format!(
        "{} {:<11} {}  ({} steps, {:.1} s)",
        if r.pass { "PASS" } else { "FAIL" },
        r.id,
        r.title,
        r.steps,
        seconds
    ))?;
    for c in &r.checks {
        let value = c.value.map_or("-".into(), |v| {
            let v = if v.abs() >= 100.0 || v == v.round() {
                format!("{v:.1}")
            } else {
                format!("{v:.3}")
            };
            if c.unit.is_empty() {
                v
            } else {
                format!("{v} {}", c.unit)
            }
        });
        say(&format!(
            "     {} {}: {value}  [{}]",
            if c.pass { "pass" } else { "FAIL" },
            c.name,
            c.criterion
        ))?;
    }
    Ok(())
}
