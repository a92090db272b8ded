//! The `gradtac` command-line tool: run a scene, explain its plan, or run the demo.

use clap::{Parser, Subcommand};
use gradtac::{demo, run, Plan, Scene};
use std::path::PathBuf;
use std::process::ExitCode;

/// GradTac tactile processing: raw taxel streams to contacts, forces and slip.
#[derive(Parser)]
#[command(name = "gradtac", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene: read its sources, run the stages its outputs need, write the outputs.
    Run {
        /// The scene file (TOML).
        scene: PathBuf,
        /// No progress bar or summary; errors are still printed.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Print the planned graph: which stages run for which sensor, and why.
    Explain {
        /// The scene file (TOML).
        scene: PathBuf,
    },
    /// Fit the one-fingertip slip-direction model from labelled recordings
    /// (`DIR/<class>/<name>.csv`, classes n e s w cw aw t) and write it as JSON for a scene's
    /// `[stages.dos] model = "…"`.
    Calibrate {
        /// Directory of labelled recordings (e.g. BioTacSP-DoS).
        data: PathBuf,
        /// Where to write the model.
        #[arg(long, short)]
        out: PathBuf,
        /// Taxel columns of the recordings.
        #[arg(long, default_value = "ff_e{1..24}")]
        columns: String,
        /// Sample rate of the recordings (Hz).
        #[arg(long, default_value_t = 100.0)]
        rate_hz: f64,
    },
    /// Render a gradtac Parquet output (any schema: frame, event, window, surface, contour,
    /// track) as a PNG.
    Plot {
        /// The Parquet file.
        input: PathBuf,
        /// The PNG to write (default: the input with `.png`).
        #[arg(long, short)]
        out: Option<PathBuf>,
    },
    /// Run the embedded demo scene on a synthetic recording, in a fresh directory.
    Demo {
        /// Where to put the demo (default: a fresh directory under the system temp dir).
        #[arg(long)]
        dir: Option<PathBuf>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_env("GRADTAC_LOG").unwrap_or_else(|_| "warn".into()))
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    match execute(cli.command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("gradtac: error: {e}");
            let mut src = std::error::Error::source(&e);
            while let Some(s) = src {
                eprintln!("  caused by: {s}");
                src = s.source();
            }
            ExitCode::FAILURE
        }
    }
}

/// Exit status of a run that Ctrl-C ended (its outputs are finished and valid).
const INTERRUPTED: u8 = 130;

fn execute(cmd: Command) -> Result<ExitCode, gradtac::Error> {
    match cmd {
        Command::Run { scene, quiet } => {
            let scene = Scene::load(&scene)?;
            let plan = Plan::new(&scene)?;
            let report = run::run_blocking(&scene, &plan, &run::RunOptions { progress: !quiet })?;
            if report.interrupted {
                eprint!("gradtac: {report}");
                return Ok(ExitCode::from(INTERRUPTED));
            }
            if !quiet {
                print!("{report}");
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Calibrate { data, out, columns, rate_hz } => {
            let opts = gradtac::calibrate::CalibrateOptions {
                columns: columns.parse().map_err(gradtac::Error::Io2)?,
                rate_hz,
                ..Default::default()
            };
            let layout = gradtac::stream::Layout::biotac_sp();
            let (model, n) = gradtac::calibrate::calibrate_dos(&data, &layout, &opts)?;
            gradtac::calibrate::write_model(&model, &out)?;
            println!(
                "calibrated on {n} recordings: {} classes, {} features, {} parameters -> {}",
                model.classes.len(),
                model.config.features.len(),
                model.parameter_count(),
                out.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Plot { input, out } => {
            let out = out.unwrap_or_else(|| input.with_extension("png"));
            let summary = gradtac::plot::plot_parquet(&input, &out)?;
            print!("{summary}");
            println!("wrote {}", out.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Explain { scene } => {
            let scene = Scene::load(&scene)?;
            let plan = Plan::new(&scene)?;
            print!("{}", plan.explain(&scene));
            Ok(ExitCode::SUCCESS)
        }
        Command::Demo { dir, quiet } => {
            let dir = match dir {
                Some(d) => d,
                None => demo::fresh_dir()?,
            };
            println!(
                "gradtac demo: a simulated two-finger grasp that slips ({}), at {} Hz",
                demo::DEMO_SLIP.name(),
                demo::RATE_HZ
            );
            let report = demo::run_demo(&dir, !quiet)?;
            print!("{report}");
            print!("{}", demo::where_lines(&report, &dir));
            Ok(ExitCode::SUCCESS)
        }
    }
}
