//! The `throng` command-line program: run built-in or file scenarios, print frame timings,
//! write pictures and trajectories, and benchmark with machine-readable output.

mod files;
mod output;
mod serve;
mod timing;
mod validate;

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Args, Parser, Subcommand};
use throng::checkpoint::RunInfo;
use throng::scenario::{self, Scenario};
use throng::timing::RunningTimings;
use throng::{Error, Result, World};

use crate::output::{MeasureOutput, Outputs};
use crate::timing::Timings;

/// A data-parallel crowd and flock simulator.
#[derive(Debug, Parser)]
#[command(name = "throng", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a built-in scenario and print frame timings.
    Demo {
        /// Built-in scenario name (see `throng list`).
        scenario: String,
        #[command(flatten)]
        run: RunArgs,
    },
    /// Run a scenario file (TOML) and print frame timings.
    Run {
        /// The scenario file.
        file: PathBuf,
        #[command(flatten)]
        run: RunArgs,
    },
    /// Time a scenario and print one JSON object.
    Bench {
        /// Built-in scenario name or scenario file.
        scenario: String,
        #[command(flatten)]
        common: CommonArgs,
        /// Untimed steps before timing.
        #[arg(long, default_value_t = 10)]
        warmup: u64,
        /// Print the result as one JSON object (the only output format).
        #[arg(long)]
        json: bool,
    },
    /// Go on with a run from a checkpoint written by `run` or `demo` with --checkpoint.
    Resume {
        /// The checkpoint file.
        file: PathBuf,
        /// Steps to run from the checkpoint (default: on to the frame the run was to end at).
        #[arg(long)]
        steps: Option<u64>,
        /// Worker threads (default: all cores); any count gives the same bits.
        #[arg(long)]
        threads: Option<usize>,
        /// Time step in seconds (default: the run's; needed for a checkpoint without one).
        #[arg(long, allow_negative_numbers = true)]
        dt: Option<f32>,
        /// Print a timing line (and write trajectory rows) every K frames.
        #[arg(long)]
        every: Option<u64>,
        /// Write the resumed run's trajectories, as `run --trajectories` does (its first frame
        /// is the checkpoint's).
        #[arg(long)]
        trajectories: Option<PathBuf>,
        /// Where to keep checkpointing (default: the file resumed from).
        #[arg(long)]
        checkpoint: Option<PathBuf>,
        /// Checkpoint every K frames (default: as the run did).
        #[arg(long)]
        checkpoint_every: Option<u64>,
        /// Print only the summary.
        #[arg(long)]
        quiet: bool,
    },
    /// Serve a live view of a scenario in the browser: watch it run, pause, step and steer it.
    Serve {
        /// Built-in scenario name or scenario file.
        scenario: String,
        #[command(flatten)]
        serve: serve::ServeArgs,
    },
    /// Run the validation suite (RiMEA's test cases, the bottleneck and fundamental-diagram
    /// experiments) and print each criterion, the measured value and pass or fail; exits
    /// non-zero when a check fails.
    Validate(validate::ValidateArgs),
    /// List the built-in scenarios.
    List,
}

/// Options shared by every command that steps a world.
#[derive(Debug, Args)]
struct CommonArgs {
    #[command(flatten)]
    world: WorldArgs,
    /// Number of steps.
    #[arg(long)]
    steps: Option<u64>,
}

/// Options that set up a world: its size, seed, time step, index, threads and memory ceiling.
#[derive(Clone, Debug, Default, Args)]
struct WorldArgs {
    /// Number of agents (shared among the scenario's groups).
    #[arg(long)]
    agents: Option<usize>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Seed of all randomness.
    #[arg(long)]
    seed: Option<u64>,
    /// Time step in seconds.
    #[arg(long, allow_negative_numbers = true)]
    dt: Option<f32>,
    /// Neighbour index backend: grid, kdtree or brute.
    #[arg(long, value_parser = ["grid", "kdtree", "brute"])]
    index: Option<String>,
    /// Memory the world may take, bytes or with K, M, G, T (default: the machine's available
    /// memory); a scenario estimated to need more is refused before it is built.
    #[arg(long, value_name = "SIZE")]
    max_memory: Option<String>,
    /// Pedestrian model of every group that has one: social_force (also sfm) or cfsm.
    #[arg(long, value_name = "MODEL", value_parser = clap::builder::PossibleValuesParser::new(throng::ped::Model::names()))]
    pedestrian_model: Option<String>,
}

/// Options of `demo` and `run`.
#[derive(Debug, Args)]
struct RunArgs {
    #[command(flatten)]
    common: CommonArgs,
    /// Print a timing line (and write trajectory rows and GIF frames) every K frames; a GIF
    /// takes about 200 frames over the run without it, at most 300 with it, and plays in under
    /// 30 s.
    #[arg(long)]
    every: Option<u64>,
    /// Write an animated GIF (`.gif`) or one frame as PNG (`.png`): the last, or, when half of
    /// the agents leave during the run, the frame at which half of them had left. Exits are
    /// hatched in green.
    #[arg(long)]
    render: Option<PathBuf>,
    /// Longest side of the picture written by --render, pixels.
    #[arg(long, default_value_t = 800)]
    size: u32,
    /// Write trajectories every --every frames and the last, in the format the extension names:
    /// .txt PedPy text (id frame x y z), .sqlite/.sqlite3/.db JuPedSim SQLite (version 2), any
    /// other long-format CSV (frame,t,id,x,y,vx,vy,heading,group).
    #[arg(long)]
    trajectories: Option<PathBuf>,
    /// Write the scenario's measurements every frame as CSV: frame,t,agents,left, then per
    /// line <name>_positive,<name>_negative (cumulative crossings), then per area
    /// <name>_count,<name>_density,<name>_speed.
    #[arg(long, value_name = "FILE")]
    measurements: Option<PathBuf>,
    /// Print only the summary.
    #[arg(long)]
    quiet: bool,
    /// Stop at the first frame at which every agent with a goal has arrived (--steps stays
    /// the ceiling); an error in a scenario with no goal (no arrival_radius, no exit).
    #[arg(long)]
    until_arrived: bool,
    /// Keep a checkpoint of the run in FILE (written crash-safe at the start, every
    /// --checkpoint-every frames and at the end; `throng resume FILE` goes on from it).
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Checkpoint every K frames (needs --checkpoint; default: only at the start and the end).
    #[arg(long, value_name = "K")]
    checkpoint_every: Option<u64>,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                let _ = e.print();
                return if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                    ExitCode::from(2)
                } else {
                    ExitCode::SUCCESS
                };
            }
            // One line: clap's first line names the bad argument and why.
            let text = e.render().to_string();
            let first = text
                .lines()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("error: bad arguments");
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
                "{} (see `throng --help`)",
                first.trim_end()
            );
            return ExitCode::from(2);
        }
    };
    match dispatch(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        // A reader that stopped reading (`throng list | head -1`) is not a failure.
        Err(e) if files::is_closed_stdout(&e) => ExitCode::SUCCESS,
        Err(e) => {
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn dispatch(command: Command) -> Result<()> {
    match command {
        Command::List => {
            for (name, _) in scenario::BUILTIN {
                let s = scenario::builtin(name)?;
                files::say(&format!("{name:<12} {}", s.description))?;
            }
            Ok(())
        }
        Command::Demo { scenario, run } => {
            let s = scenario::builtin(&scenario)?;
            run_scenario(s, &run, None)
        }
        Command::Run { file, run } => run_scenario(Scenario::load(&file)?, &run, Some(&file)),
        Command::Resume {
            file,
            steps,
            threads,
            dt,
            every,
            trajectories,
            checkpoint,
            checkpoint_every,
            quiet,
        } => {
            let args = ResumeArgs {
                steps,
                threads,
                dt,
                every,
                trajectories,
                checkpoint: checkpoint.unwrap_or_else(|| file.clone()),
                checkpoint_every,
                quiet,
            };
            resume(&file, &args)
        }
        Command::Serve { scenario, serve } => serve::serve(load_any(&scenario)?, &serve),
        Command::Bench {
            scenario,
            common,
            warmup,
            json: _,
        } => bench(load_any(&scenario)?, &common, warmup),
        Command::Validate(args) => {
            let (pool, _) = thread_pool(args.threads)?;
            validate::run(&args, &pool)
        }
    }
}

/// A built-in name, or a path to a TOML file.
fn load_any(name: &str) -> Result<Scenario> {
    let path = Path::new(name);
    if name.ends_with(".toml") || path.exists() {
        Scenario::load(path)
    } else {
        scenario::builtin(name)
    }
}

/// The files a run reads: the scenario file and the field's map file.
fn inputs(s: &Scenario, file: Option<&Path>) -> Vec<PathBuf> {
    let mut inputs: Vec<PathBuf> = file.map(Path::to_path_buf).into_iter().collect();
    if let Some(f) = &s.field
        && let scenario::MapSource::File(p) = &f.map
    {
        inputs.push(p.clone());
    }
    inputs
}

/// Applies the command-line overrides and builds the world.
fn prepare(s: Scenario, c: &CommonArgs) -> Result<(Scenario, World, rayon::ThreadPool, usize)> {
    let mut s = with_overrides(s, &c.world)?;
    if let Some(steps) = c.steps {
        s.steps = steps;
    }
    let (pool, threads) = thread_pool(c.world.threads)?;
    let world = build_world(&s, memory_limit(&c.world)?)?;
    Ok((s, world, pool, threads))
}

/// The scenario with the command line's agent count, seed, index and time step.
fn with_overrides(mut s: Scenario, c: &WorldArgs) -> Result<Scenario> {
    if let Some(n) = c.agents {
        s = s.with_agents(n)?;
    }
    if let Some(seed) = c.seed {
        s.seed = seed;
    }
    if let Some(name) = &c.pedestrian_model {
        let model = throng::ped::Model::parse(name).ok_or_else(|| Error::Invalid {
            name: "--pedestrian-model".into(),
            reason: format!("unknown model {name}"),
        })?;
        let mut any = false;
        for g in &mut s.groups {
            if let Some(p) = &mut g.params.pedestrian {
                p.set_model(model);
                any = true;
            }
        }
        if !any {
            return Err(Error::Invalid {
                name: "--pedestrian-model".into(),
                reason: format!("scenario {} has no pedestrian group", s.name),
            });
        }
    }
    if let Some(index) = &c.index {
        s.world.index = index.parse()?;
    }
    if let Some(dt) = c.dt {
        if !(dt.is_finite() && (throng::limits::MIN_DT..=throng::error::MAX_DT).contains(&dt)) {
            return Err(Error::InvalidTimeStep { dt: f64::from(dt) });
        }
        s.dt = dt;
    }
    // A layout is written out once the agent count is known, so that its geometry and its
    // measurement lines are what the run and its outputs see.
    s.expanded()
}

/// The memory a world may take when the user gives it (`--max-memory`); `None` leaves the
/// bound to the build, which reads the tightest one this process runs under when it builds
/// ([`throng::limits::memory_ceiling`]: available memory, `ulimit -v`, the control group).
fn memory_limit(c: &WorldArgs) -> Result<Option<u64>> {
    c.max_memory
        .as_deref()
        .map(throng::limits::parse_size)
        .transpose()
}

/// Builds the world of `s` within `memory` bytes given by the user, or within the process's
/// memory ceiling at this moment; errors of the build name the scenario.
fn build_world(s: &Scenario, memory: Option<u64>) -> Result<World> {
    let built = match memory {
        Some(bytes) => s.build_under(Some(throng::limits::MemoryCeiling {
            bytes,
            source: "--max-memory",
        })),
        None => s.build(),
    };
    let mut world = built.map_err(|e| match e {
        Error::Scenario { .. } | Error::Io { .. } | Error::OutOfMemory { .. } => e,
        other => Error::Scenario {
            source_name: s.name.clone(),
            location: None,
            message: other.to_string(),
        },
    })?;
    // The command owns its process and its pool: its workers wait for a step's work awake.
    world.set_workers_awake(true);
    Ok(world)
}

/// The rayon pool of `threads` workers (default: all cores, at most
/// [`throng::limits::max_threads`]) and its size.
fn thread_pool(threads: Option<usize>) -> Result<(rayon::ThreadPool, usize)> {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let threads = match threads {
        Some(t) => throng::limits::check_threads(t)?,
        None => cores,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Invalid {
            name: "threads".into(),
            reason: e.to_string(),
        })?;
    Ok((pool, threads))
}

/// A positive period given on the command line, or `default`.
fn period(name: &'static str, value: Option<u64>, default: u64) -> Result<u64> {
    match value {
        Some(0) => Err(Error::NotPositive { name, value: 0.0 }),
        Some(k) => Ok(k),
        None => Ok(default),
    }
}

/// Where and how often a run keeps its checkpoint.
struct Checkpointing {
    path: PathBuf,
    run: RunInfo,
    /// Write one before the first step (not when resuming into the file resumed from, which
    /// holds that state already).
    at_start: bool,
}

impl Checkpointing {
    /// Writes the world's checkpoint (crash-safe).
    fn write(&self, world: &World) -> Result<()> {
        world.save_file(&self.path, Some(&self.run))
    }
}

/// How `drive` steps and reports.
struct Drive<'a> {
    name: &'a str,
    dt: f32,
    /// The frame to stop at.
    end: u64,
    every: u64,
    threads: usize,
    quiet: bool,
    /// Stop once every agent with a goal has arrived.
    until_arrived: bool,
}

fn run_scenario(s: Scenario, args: &RunArgs, file: Option<&Path>) -> Result<()> {
    let outputs: Vec<(&'static str, &Path)> = [
        ("--render", args.render.as_deref()),
        ("--trajectories", args.trajectories.as_deref()),
        ("--measurements", args.measurements.as_deref()),
        ("--checkpoint", args.checkpoint.as_deref()),
    ]
    .into_iter()
    .filter_map(|(flag, p)| p.map(|p| (flag, p)))
    .collect();
    files::check_outputs(&outputs, &inputs(&s, file))?;
    if let Some(p) = &args.trajectories {
        output::Format::of(p)?;
    }
    let (s, mut world, pool, threads) = prepare(s, &args.common)?;
    if args.until_arrived
        && world.exits().is_empty()
        && !world.has_exit_stage()
        && world.groups().iter().all(|g| g.arrival_radius.is_none())
    {
        // Nothing could ever arrive: the run would silently take every step.
        return Err(Error::Invalid {
            name: "until-arrived".into(),
            reason: format!(
                "scenario {} has no goal to arrive at (no group has an `arrival_radius` and there is no exit)",
                s.name
            ),
        });
    }
    let every = period("every", args.every, (s.steps / 20).max(1))?;
    let checkpoint = match (&args.checkpoint, args.checkpoint_every) {
        (None, Some(_)) => {
            return Err(Error::Invalid {
                name: "checkpoint-every".into(),
                reason: "needs --checkpoint FILE".into(),
            });
        }
        (None, None) => None,
        (Some(path), k) => Some(Checkpointing {
            path: path.clone(),
            at_start: true,
            run: RunInfo {
                scenario: s.name.clone(),
                dt: s.dt,
                steps: s.steps,
                checkpoint_every: period("checkpoint-every", k, 0)?,
            },
        }),
    };
    let options = output::RenderOptions {
        size: args.size,
        gif: output::GifTiming::plan(s.dt, s.steps, args.every),
    };
    let sampling = output::Sampling {
        dt: s.dt,
        every,
        scenario: s.name.clone(),
        seed: world.seed(),
    };
    let outputs = Outputs::open(
        args.render.as_deref(),
        args.trajectories.as_deref().map(|p| (p, &sampling)),
        &world,
        options,
    )?;
    let measure = MeasureOutput::open(&s.measurements, args.measurements.as_deref())?;
    let drive = Drive {
        name: &s.name,
        dt: s.dt,
        end: s.steps,
        every,
        threads,
        quiet: args.quiet,
        until_arrived: args.until_arrived,
    };
    run_steps(
        &mut world,
        &pool,
        &drive,
        (outputs, Some(measure)),
        checkpoint.as_ref(),
    )
}

/// Options of `resume`.
struct ResumeArgs {
    steps: Option<u64>,
    threads: Option<usize>,
    dt: Option<f32>,
    every: Option<u64>,
    trajectories: Option<PathBuf>,
    checkpoint: PathBuf,
    checkpoint_every: Option<u64>,
    quiet: bool,
}

/// Loads a checkpoint and goes on with its run, checkpointing as it did.
fn resume(file: &Path, args: &ResumeArgs) -> Result<()> {
    if let Some(p) = &args.trajectories {
        // The checkpoint resumed from is read and (by default) rewritten, never a trajectory.
        let outputs = [
            ("--trajectories", p.as_path()),
            ("--checkpoint", &args.checkpoint),
        ];
        files::check_outputs(&outputs[..1], &[file.to_path_buf()])?;
        files::check_outputs(&outputs, &[])?;
        output::Format::of(p)?;
    }
    let (mut world, run) = World::load_file(file).map_err(|e| match e {
        Error::Checkpoint(c) => Error::Invalid {
            name: format!("checkpoint {}", file.display()),
            reason: c.to_string(),
        },
        other => other,
    })?;
    world.set_workers_awake(true);
    let (pool, threads) = thread_pool(args.threads)?;
    let dt = match (args.dt, &run) {
        (Some(dt), _) => dt,
        (None, Some(r)) => r.dt,
        (None, None) => {
            return Err(Error::Invalid {
                name: "dt".into(),
                reason: format!(
                    "the checkpoint {} holds no run settings: give --dt and --steps",
                    file.display()
                ),
            });
        }
    };
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::InvalidTimeStep { dt: f64::from(dt) });
    }
    let end = match (args.steps, &run) {
        (Some(s), _) => world.frame().saturating_add(s),
        (None, Some(r)) => r.steps.max(world.frame()),
        (None, None) => world.frame(),
    };
    let name = run
        .as_ref()
        .map_or_else(|| "checkpoint".to_string(), |r| r.scenario.clone());
    let saved_every = run.as_ref().map_or(0, |r| r.checkpoint_every);
    let checkpoint = Checkpointing {
        at_start: args.checkpoint != file,
        path: args.checkpoint.clone(),
        run: RunInfo {
            scenario: name.clone(),
            dt,
            steps: end,
            checkpoint_every: period("checkpoint-every", args.checkpoint_every, saved_every)?,
        },
    };
    let remaining = end - world.frame();
    let drive = Drive {
        name: &name,
        dt,
        end,
        every: period("every", args.every, (remaining / 20).max(1))?,
        threads,
        quiet: args.quiet,
        until_arrived: false,
    };
    let outputs = match &args.trajectories {
        Some(p) => {
            let sampling = output::Sampling {
                dt,
                every: drive.every,
                scenario: name.clone(),
                seed: world.seed(),
            };
            let options = output::RenderOptions {
                size: 0,
                gif: output::GifTiming::plan(dt, remaining, Some(drive.every)),
            };
            Outputs::open(None, Some((p, &sampling)), &world, options)?
        }
        None => Outputs::default(),
    };
    run_steps(
        &mut world,
        &pool,
        &drive,
        (outputs, None),
        Some(&checkpoint),
    )
}

/// Steps the world on to frame `d.end`: frame lines, outputs, measurements (every frame),
/// checkpoints (at the start, every `checkpoint_every` frames and at the end), the summary from
/// running statistics and the measurements' summary.
fn run_steps(
    world: &mut World,
    pool: &rayon::ThreadPool,
    d: &Drive,
    (mut outputs, mut measure): (Outputs, Option<MeasureOutput>),
    checkpoint: Option<&Checkpointing>,
) -> Result<()> {
    let steps = d.end.saturating_sub(world.frame());
    let show_progress = !d.quiet && std::io::stdout().is_terminal() && steps >= 200;
    let progress = show_progress.then(|| indicatif::ProgressBar::new(steps));
    let log = |line: String| -> Result<()> {
        match &progress {
            Some(p) => {
                p.println(line);
                Ok(())
            }
            None => files::say(&line),
        }
    };
    if !d.quiet {
        log(format!(
            "throng: scenario {} | {} agents | {steps} steps from frame {} | dt {} | {} threads | seed {}",
            d.name,
            world.len(),
            world.frame(),
            d.dt,
            d.threads,
            world.seed()
        ))?;
    }
    if let Some(c) = checkpoint
        && c.at_start
    {
        c.write(world)?;
    }
    outputs.frame(world)?;
    outputs.picture(world)?;
    if let Some(m) = &mut measure {
        m.frame(world, None)?;
    }
    let mut written = world.frame();
    let ckpt_every = checkpoint.map_or(0, |c| c.run.checkpoint_every);
    let mut timings = RunningTimings::default();
    let wall = Instant::now();
    let mut emptied = None;
    for _ in 0..steps {
        let mut stats = pool.install(|| world.step(d.dt))?;
        if let Some(m) = &mut measure {
            m.frame(world, Some(&mut stats))?;
        }
        timings.push_world(&stats, world);
        outputs.picture(world)?;
        if stats.frame % d.every == 0 {
            if !d.quiet {
                log(timing::frame_line(&stats))?;
            }
            outputs.frame(world)?;
            written = world.frame();
        }
        if let Some(c) = checkpoint
            && ckpt_every > 0
            && stats.frame % ckpt_every == 0
            && stats.frame != d.end
        {
            c.write(world)?;
        }
        if let Some(p) = &progress {
            p.inc(1);
        }
        // Done when every agent with a goal is at it.
        if d.until_arrived && timings.arrivals().all() {
            break;
        }
        // Nothing is left to simulate once every agent has left through an exit.
        if world.is_empty() && stats.frame < d.end {
            emptied = Some(stats.frame);
            break;
        }
    }
    if let Some(p) = progress {
        p.finish_and_clear();
    }
    if let Some(c) = checkpoint
        && steps > 0
    {
        c.write(world)?;
    }
    // The last frame is always written, whatever the period.
    if written != world.frame() {
        outputs.frame(world)?;
    }
    outputs.finish(world)?;
    if let Some(m) = &mut measure {
        m.finish()?;
    }
    if let Some(frame) = emptied {
        files::say(&format!(
            "stopped at frame {frame} of {}: every agent has left the world",
            d.end
        ))?;
    }
    files::say(&timings.summary(wall.elapsed()))?;
    if let Some(m) = &measure {
        for line in m.recorder().summary() {
            files::say(&line)?;
        }
    }
    Ok(())
}

fn bench(s: Scenario, c: &CommonArgs, warmup: u64) -> Result<()> {
    let (s, mut world, pool, threads) = prepare(s, c)?;
    let steps = c.steps.unwrap_or(100);
    if steps == 0 {
        return Err(Error::NotPositive {
            name: "steps",
            value: 0.0,
        });
    }
    let mut measure = throng::measure::Measurements::new(&s.measurements)?;
    measure.observe(&world);
    pool.install(|| -> Result<()> {
        for _ in 0..warmup {
            world.step(s.dt)?;
            measure.observe(&world);
        }
        Ok(())
    })?;
    let mut timings = Timings::default();
    for _ in 0..steps {
        let mut stats = pool.install(|| world.step(s.dt))?;
        measure.observe_step(&world, &mut stats);
        timings.push_world(&stats, &world);
    }
    let index = world.index_kind().to_string();
    let report = timings
        .report(&s.name, world.len(), threads, &index, steps)
        .measured(&measure);
    files::say(&timing::json(&report))
}
