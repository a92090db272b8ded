//! The `gradtac` command-line tool: run a scene, explain its plan, or run the demo.

use clap::{Parser, Subcommand};
#[cfg(feature = "plot")]
use gradtac::demo;
use gradtac::{run, Plan, Scene};
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
        /// Feature settings: a TOML file with the fields of the model's `config` (e.g.
        /// `drift_lags = [30, 60, 120]`, `features = ["drift_level", …]`); default: the
        /// built-in settings.
        #[arg(long)]
        settings: Option<PathBuf>,
        /// Variance shrinkage λ in [0, 1] toward the pooled within-class variances.
        #[arg(long, default_value_t = gradtac::stages::dos::DosModel::DEFAULT_SHRINKAGE)]
        shrinkage: f64,
        /// Gaussian class densities instead of Student t.
        #[arg(long, conflicts_with = "student_t")]
        gaussian: bool,
        /// Degrees of freedom ν of the Student-t class densities.
        #[arg(long, default_value_t = gradtac::stages::dos::DosModel::DEFAULT_STUDENT_T_DOF)]
        student_t: f64,
        /// Before fitting, print a leave-one-object-out cross-validation of these settings
        /// (objects: the leading letters of the file names, `bottle12.csv` → `bottle`), and the
        /// held-out figures of the design choice: nested leave-one-object-out and, with both
        /// BioTacSP-DoS object sets present, basic → solids and solids → basic.
        #[arg(long)]
        cross_validate: bool,
        /// Fit on the recordings only, without their mirror images across y = 0.
        #[arg(long)]
        no_mirror: bool,
        /// Also train the learned model (`dos::DosNet`, default settings, a few seconds on one
        /// core) on the same recordings and write it as JSON to this file. Measured held out it
        /// does not beat the default model (see `dos_eval`); the scene's `dos` stage runs the
        /// default model, the learned one is for library use (`DosNet`, `NetExtractor`).
        #[arg(long)]
        learned_out: Option<PathBuf>,
    },
    #[cfg(feature = "plot")]
    /// Render a gradtac Parquet output (any schema, any version: frame, event, window,
    /// surface, contour, track, slip, force, servo, dos) as an SVG or PNG figure: one file, or
    /// an archive directory (its finished `*.parquet` files, recursively, including
    /// `sensor=<name>/` partitions, read as one table; they must share one schema).
    Plot {
        /// The Parquet file or archive directory.
        input: PathBuf,
        /// The image to write: SVG when it ends in `.svg`, PNG otherwise (default: the input
        /// with `.png`; for a directory, `<dir>.png` beside it).
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// Only this sensor (repeat for several; a slip file's pair matches by either sensor).
        #[arg(long = "sensor", value_name = "NAME")]
        sensors: Vec<String>,
        /// Only rows from this many seconds after the input's first time.
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        from: Option<f64>,
        /// Only rows up to this many seconds after the input's first time.
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        to: Option<f64>,
    },
    /// Run the embedded demo scene on a synthetic recording, in a fresh directory.
    #[cfg(feature = "plot")]
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
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    let cli = Cli::parse();
    match execute(cli.command) {
        Ok(code) => code,
        Err(e) => {
            let top = e.to_string();
            // a last guard: whatever an error quotes from an input, the line stays readable
            eprintln!("gradtac: error: {}", gradtac::io::excerpt(&top, 4000));
            let mut src = std::error::Error::source(&e);
            while let Some(s) = src {
                // say it once: a cause the message already quotes is not repeated
                let cause = s.to_string();
                if !top.contains(&cause) {
                    eprintln!("  caused by: {}", gradtac::io::excerpt(&cause, 4000));
                }
                src = s.source();
            }
            ExitCode::FAILURE
        }
    }
}

/// Exit status of a run that Ctrl-C ended (its outputs are finished and valid).
const INTERRUPTED: u8 = 130;

/// `print!` to stdout, except that a closed stdout (the reader of a pipe has exited, as
/// `gradtac run … | head -1` does) ends the printing quietly instead of panicking: the outputs
/// are already finished when the report is printed. Other write errors are reported on stderr.
macro_rules! say {
    ($($t:tt)*) => { write_stdout(format_args!($($t)*)) };
}

/// [`say!`] with a newline.
macro_rules! sayln {
    () => { write_stdout(format_args!("\n")) };
    ($($t:tt)*) => { write_stdout(format_args!("{}\n", format_args!($($t)*))) };
}

fn write_stdout(args: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            eprintln!("gradtac: cannot write to stdout: {e}");
        }
    }
}

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
                say!("{report}");
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Calibrate {
            data,
            out,
            columns,
            rate_hz,
            settings,
            shrinkage,
            gaussian,
            student_t,
            cross_validate,
            no_mirror,
            learned_out,
        } => {
            let mut opts = gradtac::calibrate::CalibrateOptions {
                columns: columns.parse().map_err(gradtac::Error::Io2)?,
                rate_hz,
                shrinkage,
                student_t_dof: (!gaussian).then_some(student_t),
                mirror: !no_mirror,
                ..Default::default()
            };
            let mut reads: Vec<(&str, &std::path::Path)> = vec![("the data directory", &data)];
            reads.extend(settings.as_deref().map(|s| ("the settings file", s)));
            gradtac::guard::check_output_file(&out, &reads)?;
            if let Some(l) = &learned_out {
                let mut with_model = reads.clone();
                with_model.push(("the model output", &out));
                gradtac::guard::check_output_file(l, &with_model)?;
            }
            if let Some(path) = settings {
                opts = opts.with_settings_file(&path)?;
            }
            let layout = gradtac::stream::Layout::biotac_sp();
            let spans = gradtac::calibrate::labelled_spans(&data, &layout, &opts)?;
            if cross_validate {
                say!("these settings, fixed (in-sample if they were chosen on these recordings):\n\n");
                say!("{}", gradtac::calibrate::cross_validate_spans(&spans, &opts)?);
                say!("\nheld out — the design choice made inside every fold:\n\n");
                say!("{}", gradtac::calibrate::held_out_report(&data, &layout, &opts)?);
                sayln!();
            }
            let model = gradtac::calibrate::calibrate_spans(&spans, &opts)?;
            gradtac::calibrate::write_model(&model, &out)?;
            sayln!(
                "calibrated on {} recordings: {} classes, {} features, {} parameters -> {}",
                spans.len(),
                model.classes.len(),
                model.config.features.len(),
                model.parameter_count(),
                out.display()
            );
            if let Some(path) = learned_out {
                let recs = gradtac::calibrate::read_recordings(&data, &opts)?;
                let t = std::time::Instant::now();
                let cfg = gradtac::calibrate::TrainConfig::default();
                let net = gradtac::calibrate::train_net(&recs, &layout, &cfg)?;
                let json = serde_json::to_string_pretty(&net).map_err(|e| gradtac::Error::Scene {
                    path: path.clone(),
                    reason: format!("cannot serialise the learned model: {e}"),
                })?;
                std::fs::write(&path, json).map_err(|source| gradtac::Error::Io { path: path.clone(), source })?;
                sayln!(
                    "learned model ({}) trained on {} recordings in {:.1} s: {} parameters -> {}",
                    gradtac::calibrate::describe_net(&cfg),
                    recs.len(),
                    t.elapsed().as_secs_f64(),
                    net.parameter_count(),
                    path.display()
                );
            }
            Ok(ExitCode::SUCCESS)
        }
        #[cfg(feature = "plot")]
        Command::Plot { input, out, sensors, from, to } => {
            let out = out.unwrap_or_else(|| default_png(&input));
            gradtac::guard::check_output_file(&out, &[("the plotted input", &input)])?;
            let options = gradtac::plot::PlotOptions { sensors, from, to };
            let summary = gradtac::plot::plot_parquet_with(&input, &out, &options)?;
            say!("{summary}");
            sayln!("wrote {}", out.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Explain { scene } => {
            let scene = Scene::load(&scene)?;
            let plan = Plan::new(&scene)?;
            say!("{}", plan.explain(&scene));
            Ok(ExitCode::SUCCESS)
        }
        #[cfg(feature = "plot")]
        Command::Demo { dir, quiet } => {
            let dir = match dir {
                Some(d) => d,
                None => demo::fresh_dir()?,
            };
            sayln!(
                "gradtac demo: a simulated two-finger grasp that slips ({}), at {} Hz",
                demo::DEMO_SLIP.name(),
                demo::RATE_HZ
            );
            let report = demo::run_demo(&dir, !quiet)?;
            say!("{report}");
            say!("{}", demo::where_lines(&report, &dir));
            Ok(ExitCode::SUCCESS)
        }
    }
}

#[cfg(feature = "plot")]
/// The default PNG of `gradtac plot`: a file's path with `.png`; for a directory, `<dir>.png`
/// beside it (`.` and `..` resolved to their names first).
fn default_png(input: &std::path::Path) -> PathBuf {
    if !input.is_dir() {
        return input.with_extension("png");
    }
    let dir = match input.file_name() {
        Some(_) => input.to_path_buf(),
        None => input.canonicalize().unwrap_or_else(|_| input.to_path_buf()),
    };
    match dir.file_name() {
        Some(name) => {
            let mut png = name.to_os_string();
            png.push(".png");
            dir.with_file_name(png)
        }
        None => dir.join("plot.png"),
    }
}
