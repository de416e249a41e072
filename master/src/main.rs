//! `master`: run road, plant and controller FMUs together.
//!
//! * `master run --scenario scenarios/iso_c.json --controller hinf_of --out run.csv`
//! * `master compare --scenarios scenarios --controllers hinf_sf,hinf_of --out results`:
//!   every scenario with the passive car and each controller, in parallel, then a table per
//!   scenario, a summary, plots and `results/report.md`.
//! * `master sweep sweeps/mass_delay.json --out results/sweep`: a robustness sweep (README
//!   "Robustness sweeps"): the run table in parallel, `runs.csv`, `runs.parquet`, `report.md`,
//!   `cdf.svg` and `map.svg`.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use master::cosim::{run, MasterError, Scenario};
use master::report::{
    design_table, figures, limits_table, load_designs, orders_table, plot, real_car_table,
    scenario_table, split_table, summary_table, Figures,
};
use master::structure::Loop;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    about = "Co-simulation master for the suspension FMUs (road -> plant -> controller, Gauss-Seidel)"
)]
struct Cli {
    /// Directory with road.fmu, plant.fmu and the controller FMUs.
    #[arg(long, default_value = "dist", global = true)]
    dist: PathBuf,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// One scenario with one controller (or the passive car), written as CSV.
    Run {
        /// The scenario file (JSON; README "The master and the comparison").
        #[arg(long)]
        scenario: PathBuf,
        /// A controller FMU: its name in --dist, or a path to an .fmu; omit for the passive car.
        #[arg(long)]
        controller: Option<String>,
        /// The CSV to write: time and every recorded variable at each communication point.
        #[arg(long)]
        out: PathBuf,
    },
    /// Write an OSP system structure (libcosim, OSP tools) of one scenario with one controller;
    /// `--out` should be in --dist, beside the FMUs it names.
    Osp(LoopArgs),
    /// Write an SSP 1.0 archive (`SystemStructure.ssd` and the three FMUs) of one scenario with
    /// one controller, for SSP-capable tools.
    Ssp(LoopArgs),
    /// Every scenario with the passive car and each controller: tables, plots, report.
    Compare {
        /// A scenario file or a directory of them.
        #[arg(long, default_value = "scenarios")]
        scenarios: PathBuf,
        /// Comma-separated controller FMU names.
        #[arg(long, value_delimiter = ',')]
        controllers: Vec<String>,
        /// Directory for report.md, one SVG per scenario and the CSV of every run.
        #[arg(long, default_value = "results")]
        out: PathBuf,
        /// `synth`'s dist/synthesis.json: adds the design table (γ, certificate, synthesis time,
        /// comfort in each design's own scenario against passive and its nominal design).
        #[arg(long)]
        designs: Option<PathBuf>,
    },
    /// A robustness sweep: a base scenario with parameters swept over grids or seeded
    /// distributions, every point with every controller, in parallel; one row per run in
    /// runs.csv and runs.parquet, statistics and a worst-case map in report.md, CDFs in cdf.svg,
    /// the worst-case map in map.svg.
    Sweep {
        /// The sweep file (JSON; README "Robustness sweeps").
        spec: PathBuf,
        /// Directory for runs.csv, runs.parquet, report.md, cdf.svg and map.svg.
        #[arg(long, default_value = "results/sweep")]
        out: PathBuf,
        /// Only the runs `START..END` of the run table (0-based, END excluded): a chunk of a
        /// sweep shared across machines; the rows keep their run numbers.
        #[arg(long, value_parser = parse_range)]
        runs: Option<std::ops::Range<usize>>,
        /// Print the run table's size and exit without running.
        #[arg(long)]
        dry_run: bool,
    },
    /// Print the JSON Schema of a scenario or a sweep file (checked in as
    /// schemas/scenario.schema.json and schemas/sweep.schema.json).
    Schema {
        /// Which file format.
        #[arg(value_enum)]
        kind: SchemaKind,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum SchemaKind {
    Scenario,
    Sweep,
}

fn parse_range(s: &str) -> Result<std::ops::Range<usize>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("'{s}' is not START..END"))?;
    let (a, b) = (
        a.parse::<usize>().map_err(|e| format!("'{a}': {e}"))?,
        b.parse::<usize>().map_err(|e| format!("'{b}': {e}"))?,
    );
    if a > b {
        return Err(format!("{a}..{b}: START is after END"));
    }
    Ok(a..b)
}

/// One scenario with one controller, described for another tool.
#[derive(clap::Args)]
struct LoopArgs {
    /// The scenario file whose parameters, step and duration the structure carries.
    #[arg(long)]
    scenario: PathBuf,
    /// The controller FMU's name in --dist.
    #[arg(long)]
    controller: String,
    /// The file to write.
    #[arg(long)]
    out: PathBuf,
}

fn scenarios_in(path: &Path) -> Result<Vec<Scenario>, MasterError> {
    if path.is_file() {
        return Ok(vec![Scenario::load(path)?]);
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .map_err(|e| MasterError(format!("cannot read {}: {e}", path.display())))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(MasterError(format!(
            "no scenario (*.json) in {}",
            path.display()
        )));
    }
    files.iter().map(|f| Scenario::load(f)).collect()
}

/// `f` of every job in parallel (one job per task: runs differ in length), in order, with a
/// progress bar and its ETA; and the wall time [s].
fn in_parallel<T: Sync, R: Send>(jobs: &[T], f: impl Fn(&T) -> R + Sync) -> (Vec<R>, f64) {
    let bar = ProgressBar::new(jobs.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs {elapsed} ETA {eta} {msg}")
            .expect("valid template"),
    );
    let t0 = std::time::Instant::now();
    let out = jobs
        .par_iter()
        .with_max_len(1)
        .map(|j| {
            let r = f(j);
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    (out, t0.elapsed().as_secs_f64())
}

/// Each run of a controller in a scenario whose plant is not the car it was designed for:
/// `(scenario, controller, why)`, warned about on stderr.
fn off_design_runs(
    dist: &Path,
    scenarios: &[Scenario],
    controllers: &[String],
) -> Result<Vec<(String, String, Vec<String>)>, MasterError> {
    let plant = master::cosim::Fmu::load(dist, "plant")?;
    let mut out = Vec::new();
    for c in controllers {
        // Read once per controller, not once per scenario.
        let Some(designed) = master::cosim::Fmu::load(dist, c)?.designed_for()? else {
            continue;
        };
        for s in scenarios.iter().filter(|s| s.wants(c)) {
            let why = master::cosim::off_design(s, &plant, &designed);
            if !why.is_empty() {
                eprintln!(
                    "warning: {c} runs off the car it was designed for in {}: {}",
                    s.name,
                    why.join("; ")
                );
                out.push((s.name.clone(), c.clone(), why));
            }
        }
    }
    Ok(out)
}

fn compare(
    dist: &Path,
    scenarios: &[Scenario],
    controllers: &[String],
    out: &Path,
    designs: Option<&Path>,
) -> Result<String, MasterError> {
    let designs = designs.map(load_designs).transpose()?;
    let off_design = off_design_runs(dist, scenarios, controllers)?;
    let io = |e: std::io::Error| MasterError(format!("{}: {e}", out.display()));
    std::fs::create_dir_all(out).map_err(io)?;
    let jobs: Vec<(usize, Option<String>)> = scenarios
        .iter()
        .enumerate()
        .flat_map(|(i, s)| {
            std::iter::once((i, None)).chain(
                controllers
                    .iter()
                    .filter(|c| s.wants(c))
                    .map(move |c| (i, Some(c.clone()))),
            )
        })
        .collect();
    let (runs, wall) = in_parallel(&jobs, |(i, c)| {
        run(dist, &scenarios[*i], c.as_deref())
            .map(|r| (*i, c.clone().unwrap_or_else(|| "passive".into()), r))
    });
    let runs: Vec<_> = runs.into_iter().collect::<Result<_, _>>()?;
    let mut tables = String::new();
    let mut all: Vec<Vec<(String, Figures)>> = Vec::new();
    for (i, s) in scenarios.iter().enumerate() {
        let mine: Vec<&(usize, String, master::cosim::Run)> =
            runs.iter().filter(|r| r.0 == i).collect();
        let dir = out.join(&s.name);
        std::fs::create_dir_all(&dir).map_err(io)?;
        for (_, name, r) in &mine {
            r.write_csv(&dir.join(format!("{name}.csv")))?;
        }
        let figs: Vec<(String, Figures)> = mine
            .iter()
            .map(|(_, n, r)| (n.clone(), figures(r, s)))
            .collect();
        plot(
            &out.join(format!("{}.svg", s.name)),
            s,
            &mine
                .iter()
                .map(|(_, n, r)| (n.clone(), r))
                .collect::<Vec<_>>(),
        )?;
        tables += &scenario_table(s, &figs);
        tables += &format!("\n![{0}]({0}.svg)\n\n", s.name);
        all.push(figs);
    }
    let summary = summary_table(scenarios, &all, controllers);
    let design_table = designs.as_ref().map(|d| design_table(d, scenarios, &all));
    let mut report = String::from("# Closed-loop comparison\n\nGenerated by `master compare` (`make`): road, plant and controller FMUs from `dist/` through the `fmi` crate, Gauss-Seidel road -> plant -> controller at a fixed communication step. Seat acceleration weighted by ISO 2631-1 W_k; each figure also as % of the passive car in the same scenario. CSV of every run under `results/<scenario>/`.\n\n## Summary: W_k RMS seat acceleration [m/s²]\n\n");
    report += &summary;
    report += &format!("\n{} runs in {wall:.1} s wall time.\n\n", runs.len());
    if let Some(t) = &design_table {
        report += "## The designs: certificates and comfort in their own scenario\n\nWhat each design claims (γ, or the W_k seat RMS its certificate predicts on its design road), what is certified over its uncertainty, and the synthesis time, from `synth` (`dist/synthesis.json`, certificates in `dist/<variant>.certificate.json`); W_k RMS seat acceleration from the runs below, against the passive car and against the design's nominal counterpart in the same scenario.\n\n";
        report += t;
        report += "\n";
    }
    let baselines: Vec<String> = controllers
        .iter()
        .filter(|c| master::certified::role(dist, c).as_deref() == Some("baseline"))
        .cloned()
        .collect();
    if let Some(t) = real_car_table(scenarios, &all, controllers, &baselines) {
        report += &format!("## On a real car\n\nOn `hills` (ISO C at 20 m/s over 1 m hills every 200 m, 10 Hz actuators, the plant's sensor model on: noise and bias) each controller's W_k RMS seat acceleration against the passive car's and the `skyhook` baseline's; and the scenarios off the design model ({}) in which it does not hold: no better than the passive car anywhere; at a force limit {:.0} % of the time or more on {} (a grade, a crossfall and long waves hold no force in steady state; on the rough roads, with slow actuators or an actuator lost a limit is the scenario's physics and the figure against the passive car says whether the loop stays stable); and, for a design (not a baseline: {}), on `hills` above {} × the passive car's W_k seat or less than {} % better than `skyhook`'s.\n\n",
            master::report::REAL_CAR_SCENARIOS.map(|s| format!("`{s}`")).join(", "),
            100.0 * master::report::FORCE_LIMIT_SHARE,
            master::report::FORCE_LIMIT_SCENARIOS.map(|s| format!("`{s}`")).join(", "),
            if baselines.is_empty() { "none".to_string() } else { baselines.iter().map(|b| format!("`{b}`")).collect::<Vec<_>>().join(", ") },
            master::report::HILLS_OF_PASSIVE,
            100.0 * master::report::HILLS_BELOW_SKYHOOK,
        );
        report += &t;
        report += "\n";
    }
    if let Some(t) = split_table(scenarios, &all, controllers) {
        report += "## Where the comfort comes from: body control and seat isolation\n\nThe same class C road with every actuator (`iso_c`), with the corner actuators alone (`seat_lost`: body control; the seat rides on its passive spring and damper) and with the seat actuator alone (`corners_lost`: seat isolation on a passive body). W_k RMS seat acceleration [m/s²] and W_e RMS roll and pitch acceleration [rad/s²], each against the passive car's.\n\n";
        report += &t;
        report += "\n";
    }
    if let Some(t) = designs
        .as_ref()
        .and_then(|d| orders_table(d, scenarios, &all))
    {
        report += "## Master orders\n\nThe class C road of `iso_c` in each order a master may run the loop (the scenario's `order`): `GaussSeidel`, the plant's outputs to the controller, its command to the plant, then every FMU steps (this report's order and FMPy's); `Jacobi`, every output read before any input is set (the command the controller gives with its previous input; libcosim's fixed-step algorithm); `ControllerFirst`, the controller stepped first, its command at the end of the step driving the plant over it. W_k RMS seat acceleration [m/s²] measured, and in brackets what the design's certificate predicts for the loop in that order at its communication step (`comfort.master_orders`), or why it predicts nothing. A controller with a parameter `master_order` (`delay_sf`'s predictor, whose commands in flight depend on the order) is told the order it runs in. One 10 s run of one seed is not the design road's mean: `master/tests/comfort_prediction.rs` measures each order against its prediction on 60 s runs of the design road (3 seeds, relative to the default order's 12 or more on the same roads).\n\n";
        report += &t;
        report += "\n";
    }
    report += &fmi3_section(dist, scenarios, &jobs, &runs)?;
    report += &format!("## Limits and model validity\n\nRuns marked ⚠ above: a wheel that leaves the road (its tyre load down to zero, where the linear tyre model no longer holds), a suspension stroke beyond the scenario's `stroke_max` ({} cm unless it says otherwise), or actuators at their force limits (the share of the time any one is: its command, delayed by the plant's `tau`, at or beyond `u_max` or `u_max_seat`). Over each scenario's metrics window.\n\n{}\n", 100.0 * master::cosim::DEFAULT_STROKE_MAX, limits_table(scenarios, &all));
    if !off_design.is_empty() {
        report += "## Runs off the car a controller was designed for\n\nThe plant of these runs differs from the car recorded in the controller's `resources/controller.json` (`designed_for`, from `synth --vehicle`): a sprung mass outside the range a robust design covers, or any other vehicle parameter. Scenarios do this on purpose to test robustness; outside them it means the controller was designed for another car.\n\n| scenario | controller | plant differs |\n|---|---|---|\n";
        for (s, c, why) in &off_design {
            report += &format!("| {s} | `{c}` | {} |\n", why.join("; "));
        }
        report += "\n";
    }
    let warned: Vec<_> = runs.iter().filter(|r| !r.2.warnings.is_empty()).collect();
    if !warned.is_empty() {
        report += "## Warnings of the FMUs\n\nWhat an FMU answered `fmi2Warning` for in a run that went on: a controller stepped beyond the communication steps its certificate calls stable (`comfort.communication_steps`), whose figures above are then not those of the loop it was designed for.\n\n| scenario | controller | warning |\n|---|---|---|\n";
        for (i, c, r) in warned {
            for w in &r.warnings {
                report += &format!(
                    "| {} | `{c}` | {} |\n",
                    scenarios[*i].name,
                    w.replace('|', "\\|")
                );
            }
        }
        report += "\n";
    }
    report += "## Scenarios\n\n";
    report += &tables;
    std::fs::write(out.join("report.md"), report).map_err(io)?;
    Ok(format!("W_k RMS seat acceleration [m/s²] (vs passive):\n\n{summary}\n{}{} runs in {wall:.1} s; report: {}\n", design_table.map(|t| format!("Designs:\n\n{t}\n")).unwrap_or_default(), runs.len(), out.join("report.md").display()))
}

/// `## FMI 3.0`: every run of the comparison again with the FMI 3.0 FMUs of `<dist>/fmi3/`
/// (the same model code behind FMI 3.0's functions), each against its FMI 2.0 run: identical bit
/// for bit, or the largest difference of a recorded value. Says so when there are none.
fn fmi3_section(
    dist: &Path,
    scenarios: &[Scenario],
    jobs: &[(usize, Option<String>)],
    runs: &[(usize, String, master::cosim::Run)],
) -> Result<String, MasterError> {
    let fmi3 = dist.join("fmi3");
    let mut section = String::from("## FMI 3.0\n\n");
    if !fmi3.join("plant.fmu").exists() {
        section += &format!("Not run: {} holds no FMI 3.0 FMUs.\n\n", fmi3.display());
        return Ok(section);
    }
    let (again, wall) = in_parallel(jobs, |(i, c)| run(&fmi3, &scenarios[*i], c.as_deref()));
    let mut differ = Vec::new();
    for ((i, name, two), three) in runs.iter().zip(again) {
        let three = three?;
        if three.time != two.time || three.data != two.data {
            let largest = two
                .data
                .iter()
                .zip(&three.data)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            differ.push(format!(
                "| {} | `{name}` | {largest:.3e} |\n",
                scenarios[*i].name
            ));
        }
    }
    section += &format!(
        "Every run above again with the FMI 3.0 FMUs of `dist/fmi3/` (the same libraries behind \
         FMI 3.0's functions, through the `fmi` crate's FMI 3.0 import; {wall:.1} s wall time): \
         {} of {} identical to its FMI 2.0 run bit for bit.\n\n",
        runs.len() - differ.len(),
        runs.len()
    );
    if !differ.is_empty() {
        section +=
            "| scenario | controller | largest difference of a recorded value |\n|---|---|---|\n";
        section += &differ.concat();
        section += "\n";
    }
    Ok(section)
}

fn sweep(
    dist: &Path,
    spec: &Path,
    out: &Path,
    runs: Option<std::ops::Range<usize>>,
    dry_run: bool,
) -> Result<String, MasterError> {
    use master::sweep::{Fmus, Sweep};
    use master::sweep_out::{csv, plot_cdf, plot_map, report, write_parquet, WorstMap};
    let sweep = Sweep::load(spec)?;
    let all = sweep.jobs()?;
    let total = all.len();
    let jobs = match runs {
        Some(r) if r.end > total => {
            return Err(MasterError(format!(
                "--runs {}..{}: the run table has {total} runs",
                r.start, r.end
            )))
        }
        Some(r) => all[r].to_vec(),
        None => all,
    };
    if dry_run {
        return Ok(format!(
            "{}: {total} runs ({} points x {} controllers); would run {}\n",
            sweep.spec.name,
            total / sweep.spec.controllers.len(),
            sweep.spec.controllers.len(),
            jobs.len()
        ));
    }
    let fmus = Fmus::load(dist, &sweep.spec.controllers)?;
    // Before any run: a certificate that cannot be read stops the sweep.
    let certified: Vec<_> = sweep
        .spec
        .controllers
        .iter()
        .filter(|c| *c != "passive")
        .map(|c| master::certified::load(dist, c))
        .collect::<Result<Vec<_>, _>>()?
        .into_iter()
        .flatten()
        .collect();
    let io = |e: std::io::Error| MasterError(format!("{}: {e}", out.display()));
    std::fs::create_dir_all(out).map_err(io)?;
    let (rows, wall) = in_parallel(&jobs, |j| fmus.run(j));
    let names = sweep.parameter_names();
    std::fs::write(out.join("runs.csv"), csv(&names, &rows)).map_err(io)?;
    write_parquet(&out.join("runs.parquet"), &names, &rows)?;
    let map = WorstMap::new(&sweep, &rows);
    let text = report(&sweep, &rows, map.as_ref(), wall)
        + &master::certified::section(&certified, &rows, |c, r| {
            c.condition_of(&r.job.scenario, |p| fmus.plant().start_real(p))
        });
    std::fs::write(out.join("report.md"), &text).map_err(io)?;
    plot_cdf(&out.join("cdf.svg"), &sweep, &rows)?;
    if let Some(map) = &map {
        plot_map(&out.join("map.svg"), &sweep, map)?;
    }
    let failed = rows
        .iter()
        .filter(|r| r.outcome.finished().is_none())
        .count();
    Ok(format!(
        "{} runs ({failed} failed) in {wall:.1} s; {}\n",
        rows.len(),
        out.join("report.md").display()
    ))
}

fn main() {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Run {
            scenario,
            controller,
            out,
        } => Scenario::load(scenario).and_then(|s| {
            if let Some(c) = controller {
                off_design_runs(&cli.dist, std::slice::from_ref(&s), std::slice::from_ref(c))?;
            }
            let r = run(&cli.dist, &s, controller.as_deref())?;
            r.write_csv(out)?;
            for w in &r.warnings {
                eprintln!("warning: {w}");
            }
            let values = master::sweep::metric_values(&figures(&r, &s));
            let metrics: String = master::sweep::METRICS
                .iter()
                .zip(values)
                .map(|(name, v)| format!("  {name:<22} {v:.6}\n"))
                .collect();
            Ok(format!(
                "wrote {} ({} steps, loop {:.4} s, {:.0}x real time)\nmetrics{}:\n{metrics}",
                out.display(),
                r.time.len(),
                r.loop_seconds,
                s.duration / r.loop_seconds,
                if s.metrics_from > 0.0 {
                    format!(" over t > {} s", s.metrics_from)
                } else {
                    String::new()
                }
            ))
        }),
        Command::Osp(LoopArgs {
            scenario,
            controller,
            out,
        }) => Scenario::load(scenario)
            .and_then(|s| Loop::new(&cli.dist, &s, controller))
            .and_then(|l| {
                std::fs::write(out, l.osp())
                    .map_err(|e| MasterError(format!("cannot write {}: {e}", out.display())))
            })
            .map(|_| format!("wrote {}\n", out.display())),
        Command::Ssp(LoopArgs {
            scenario,
            controller,
            out,
        }) => Scenario::load(scenario)
            .and_then(|s| Loop::new(&cli.dist, &s, controller))
            .and_then(|l| l.write_ssp(&cli.dist, out))
            .map(|_| format!("wrote {}\n", out.display())),
        Command::Compare {
            scenarios,
            controllers,
            out,
            designs,
        } => scenarios_in(scenarios)
            .and_then(|s| compare(&cli.dist, &s, controllers, out, designs.as_deref())),
        Command::Sweep {
            spec,
            out,
            runs,
            dry_run,
        } => sweep(&cli.dist, spec, out, runs.clone(), *dry_run),
        Command::Schema { kind } => Ok(match kind {
            SchemaKind::Scenario => master::schema::scenario(),
            SchemaKind::Sweep => master::schema::sweep(),
        }),
    };
    match result {
        Ok(msg) => print!("{msg}"),
        Err(e) => {
            eprintln!("master: {e}");
            std::process::exit(1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn every_option_of_every_command_says_what_it_is() {
        let cli = Cli::command();
        cli.clone().debug_assert();
        let mut undocumented = Vec::new();
        for command in std::iter::once(&cli).chain(cli.get_subcommands()) {
            for arg in command.get_arguments() {
                if arg.get_help().is_none() && arg.get_id() != "help" {
                    undocumented.push(format!("{} --{}", command.get_name(), arg.get_id()));
                }
            }
        }
        assert!(undocumented.is_empty(), "no --help text: {undocumented:?}");
    }
}
