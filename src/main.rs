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

// parsed once per process: the variants' sizes do not matter
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// Run a scene: read its sources, run the stages its outputs need, write the outputs.
    Run {
        /// The scene file (TOML).
        scene: PathBuf,
        /// No progress bar or summary; errors are still printed.
        #[arg(long, short)]
        quiet: bool,
        /// Threads for the sensors' chains (default: the available cores; 1: one thread).
        /// The outputs are the same byte for byte whatever the number.
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        #[cfg(feature = "view")]
        #[command(flatten)]
        view: ViewArgs,
    },
    /// Run a scene once per recording, on a pool of threads, into one hive-partitioned archive
    /// (`OUT/<output>/recording=<stem>/sensor=<name>/part-000000.parquet`; see docs/batch.md).
    /// Every file the scene's sensors read is replaced by the recording. A recording that
    /// fails is reported (one line: file and reason) and does not stop the others; the exit
    /// status is non-zero if any failed.
    Batch {
        /// The scene file (TOML); its sensors must read one file (and no live source).
        scene: PathBuf,
        /// The recordings: paths or glob patterns (`'data/**/*.csv'`, quoted so that gradtac
        /// expands them).
        #[arg(required = true, value_name = "RECORDINGS")]
        recordings: Vec<String>,
        /// The archive's directory.
        #[arg(long, short)]
        out: PathBuf,
        /// Recordings run at once (default: the available cores).
        #[arg(long, short, value_name = "N")]
        jobs: Option<usize>,
        /// No progress bar or summary; failures are still printed.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Replay gradtac Parquet outputs (a file, a run's output directory or an archive; any
    /// schema, any version) into a rerun viewer, or into an `.rrd` recording with `--save`.
    #[cfg(all(feature = "view", feature = "plot"))]
    View {
        /// The Parquet file or directory (read recursively).
        input: PathBuf,
        /// Write an `.rrd` recording here instead of showing a viewer.
        #[arg(long, value_name = "RRD")]
        save: Option<PathBuf>,
        /// Stream to the viewer at this URL instead of spawning one
        /// (e.g. `rerun+http://127.0.0.1:9876/proxy`).
        #[arg(long, value_name = "URL", conflicts_with = "save")]
        url: Option<String>,
    },
    /// Print the planned graph: which stages run for which sensor, and why.
    Explain {
        /// The scene file (TOML).
        scene: PathBuf,
    },
    /// Fit a model from recordings: `calibrate force SCENE --force-column NAME --out force.json`
    /// (force from a gauge), `calibrate baseline SCENE --out tare.json` (a stored untouched
    /// baseline), or the one-fingertip slip-direction model from labelled recordings
    /// (`calibrate DIR -o m.json`, also `calibrate dos DIR -o m.json`; `DIR/<class>/<name>.csv`,
    /// classes n e s w cw aw t) as JSON for a scene's `[stages.dos] model = "…"`.
    #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
    Calibrate {
        #[command(subcommand)]
        what: Option<CalibrateWhat>,
        #[command(flatten)]
        dos: DosArgs,
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
        #[cfg(feature = "view")]
        #[command(flatten)]
        view: ViewArgs,
    },
}

/// The rerun view of a run (feature `view`).
#[cfg(feature = "view")]
#[derive(clap::Args)]
struct ViewArgs {
    /// Show the run in a rerun viewer (rerun 0.36): spawn one (`rerun` on PATH), or stream to
    /// the one already listening on the default port.
    #[arg(long)]
    view: bool,
    /// Write the view as an `.rrd` recording (no viewer needed).
    #[arg(long, value_name = "RRD", conflicts_with = "view_url")]
    view_save: Option<PathBuf>,
    /// Stream the view to the viewer at this URL (e.g. `rerun+http://127.0.0.1:9876/proxy`).
    #[arg(long, value_name = "URL")]
    view_url: Option<String>,
    /// Drop view records when the viewer is slower than the run, even for file sources (live
    /// CAN buses always drop: the pipeline never waits for the viewer). Without it a run of
    /// files, whose pace is the reader's, waits so that the view is complete.
    #[arg(long)]
    view_drop: bool,
}

#[cfg(feature = "view")]
impl ViewArgs {
    /// The view asked for, opened (`None`: no view). `live`: a source is a live bus.
    fn open(&self, live: bool) -> Result<Option<gradtac::view::View>, gradtac::Error> {
        use gradtac::view::{View, ViewOptions, ViewTarget};
        let target = match (&self.view_save, &self.view_url, self.view) {
            (Some(p), _, _) => ViewTarget::Save(p.clone()),
            (None, Some(u), _) => ViewTarget::Connect(u.clone()),
            (None, None, true) => ViewTarget::Spawn,
            (None, None, false) => return Ok(None),
        };
        let options = ViewOptions { lossless: !(live || self.view_drop), ..ViewOptions::default() };
        View::open(&target, &options).map(Some)
    }
}

/// Does the scene read a live CAN bus?
#[cfg(feature = "view")]
fn reads_live_bus(scene: &Scene) -> bool {
    scene.buses.iter().any(|b| !matches!(b.source, gradtac::scene::BusSource::Candump(_)))
}

/// `gradtac calibrate [dos] DIR -o m.json`: the slip-direction model.
#[derive(clap::Args)]
struct DosArgs {
    /// Directory of labelled recordings (e.g. BioTacSP-DoS).
    data: Option<PathBuf>,
    /// Where to write the model.
    #[arg(long, short)]
    out: Option<PathBuf>,
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
    /// Write the Student-t model alone, without the window part (by default the tree part:
    /// gradient-boosted trees and the weight of the combined score, chosen by
    /// leave-one-object-out, which fits the trees once per object and once on all: ≈ 30–45 s on
    /// the 167 BioTacSP-DoS development recordings).
    #[arg(long)]
    no_window: bool,
    /// Write the window part as the window net (`dos::DosWindowNet`, with the motion inputs;
    /// the default of stop 32) instead of the trees.
    #[arg(long, conflicts_with = "no_window")]
    window_net: bool,
    /// Write the window net without its four motion inputs about the contact's own centre (its
    /// drift and the turn of its principal axis since contact): the window net of stop 31
    /// (implies `--window-net`).
    #[arg(long, conflicts_with = "no_window")]
    no_window_motion: bool,
    /// The window part as gradient-boosted trees over a per-taxel time representation of the
    /// contact (`dos::DosTrees`; T15, the rule winner of stop 36's round 6, see the `dos` module docs): the
    /// default since stop 34 (the flag is kept for scripts that name it).
    #[arg(long, conflicts_with_all = ["no_window", "no_window_motion", "window_net"])]
    window_trees: bool,
    /// Also train the learned model (`dos::DosNet`, default settings, a few seconds on one
    /// core) on the same recordings and write it as JSON to this file. Measured held out it
    /// does not beat the default model (see `dos_eval`); the scene's `dos` stage runs the
    /// default model, the learned one is for library use (`DosNet`, `NetExtractor`).
    #[arg(long)]
    learned_out: Option<PathBuf>,
}

/// What `gradtac calibrate` fits.
#[derive(Subcommand)]
enum CalibrateWhat {
    /// Force from a gauge: the scene's one sensor names the recording (any source); the
    /// gauge's newtons are a column of the same CSV (`--force-column`) or of a CSV of their
    /// own (`--force-file`, matched by time). Writes a model for `[stages.force] model = "…"`.
    Force {
        /// The scene whose sensor names the recording.
        scene: PathBuf,
        /// The column of measured newtons.
        #[arg(long, value_name = "NAME")]
        force_column: String,
        /// A CSV holding the force column and a time column, for sources other than CSV.
        #[arg(long, value_name = "CSV")]
        force_file: Option<PathBuf>,
        /// The time column of --force-file (the recording's clock).
        #[arg(long, default_value = "time", value_name = "NAME", requires = "force_file")]
        force_time_column: String,
        /// Unit of --force-time-column: s, ms, us or ns.
        #[arg(long, default_value = "s", value_name = "UNIT", requires = "force_file")]
        force_time_unit: String,
        /// The sensor (default: the scene's only one).
        #[arg(long)]
        sensor: Option<String>,
        /// The method: forward (the sensor's forward model identified from the gauge session and
        /// inverted per frame; the placed law is written instead, with a note, when the model
        /// predicts each calibration press, fitted without it, worse than the placed law does —
        /// with fewer than 3 presses, when it fits its calibration worse; docs/force.md), placed
        /// (a power law in the total baseline-relative change divided by the layout's response
        /// at the contact's place),
        /// total (the same without the division), ridge (on the 24 changes), area (contour area
        /// of the scene's contact location) or amplitude (the contact fit's, with method = "fit").
        #[arg(long, default_value = gradtac::stages::force_model::DEFAULT_METHOD.name())]
        method: String,
        /// Where to write the model (JSON).
        #[arg(long, short)]
        out: PathBuf,
    },
    /// A stored untouched baseline from a stretch of the scene's one sensor without contact,
    /// for `[stages.locate] baseline = "…"` (contact from a recording's first frame).
    Baseline {
        /// The scene whose sensor names the recording.
        scene: PathBuf,
        /// The sensor (default: the scene's only one).
        #[arg(long)]
        sensor: Option<String>,
        /// Start of the untouched stretch (s after the first frame).
        #[arg(long, default_value_t = 0.0)]
        from: f64,
        /// End of the untouched stretch (s after the first frame; default: the end).
        #[arg(long)]
        to: Option<f64>,
        /// Where to write the baseline (JSON).
        #[arg(long, short)]
        out: PathBuf,
    },
    /// The slip-direction model (the same as `gradtac calibrate DIR -o m.json`).
    Dos(DosArgs),
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
            // one line: a dependency's message may span several (arrow's flatbuffer verifier)
            let top = e.to_string().split_whitespace().collect::<Vec<_>>().join(" ");
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
        Command::Run {
            scene,
            quiet,
            threads,
            #[cfg(feature = "view")]
            view,
        } => {
            let threads = threads.unwrap_or(0);
            let scene = Scene::load(&scene)?;
            #[cfg(feature = "view")]
            if let Some(rrd) = &view.view_save {
                gradtac::guard::check_side_output(&scene, rrd)?;
            }
            let plan = Plan::new(&scene)?;
            #[cfg(feature = "view")]
            let view = view.open(reads_live_bus(&scene))?;
            let options = run::RunOptions {
                progress: !quiet,
                threads,
                #[cfg(feature = "view")]
                view: view.as_ref().map(gradtac::view::View::handle),
            };
            let report = run::run_blocking(&scene, &plan, &options);
            #[cfg(feature = "view")]
            {
                drop(options);
                finish_view(view, quiet)?;
            }
            let report = report?;
            if report.interrupted {
                eprint!("gradtac: {report}");
                return Ok(ExitCode::from(INTERRUPTED));
            }
            if !quiet {
                say!("{report}");
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Batch { scene, recordings, out, jobs, quiet } => {
            let scene = Scene::load(&scene)?;
            let recordings = expand_recordings(&recordings)?;
            let opts = gradtac::batch::BatchOptions { jobs: jobs.unwrap_or(0), progress: !quiet };
            let report = gradtac::batch::run_batch(&scene, &recordings, &out, &opts)?;
            for (r, e) in &report.failed {
                eprintln!(
                    "gradtac: failed: {}: {}",
                    r.display(),
                    gradtac::io::excerpt(&e.to_string(), 2000).replace('\n', " ")
                );
            }
            let summary = report.to_string();
            let last = summary.lines().last().unwrap_or_default();
            if !quiet {
                sayln!("{last}");
            } else if !report.failed.is_empty() {
                eprintln!("gradtac: {last}");
            }
            Ok(match (report.skipped, report.failed.len()) {
                (s, _) if s > 0 => ExitCode::from(INTERRUPTED),
                (_, 0) => ExitCode::SUCCESS,
                _ => ExitCode::FAILURE,
            })
        }
        #[cfg(all(feature = "view", feature = "plot"))]
        Command::View { input, save, url } => {
            use gradtac::view::{View, ViewOptions, ViewTarget};
            let target = match (save, url) {
                (Some(p), _) => {
                    gradtac::guard::check_output_file(&p, &[("the replayed input", &input)])?;
                    ViewTarget::Save(p)
                }
                (None, Some(u)) => ViewTarget::Connect(u),
                (None, None) => ViewTarget::Spawn,
            };
            // a replay has no pace to keep: every row is logged
            let view = View::open(&target, &ViewOptions { lossless: true, ..ViewOptions::default() })?;
            let summary = gradtac::view::replay(&input, &view.handle())?;
            say!("{summary}");
            finish_view(Some(view), false)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Calibrate { what, dos } => match what {
            None | Some(CalibrateWhat::Dos(_)) => {
                let dos = match what {
                    Some(CalibrateWhat::Dos(d)) => d,
                    _ => dos,
                };
                calibrate_dos(dos)
            }
            Some(CalibrateWhat::Force {
                scene,
                force_column,
                force_file,
                force_time_column,
                force_time_unit,
                sensor,
                method,
                out,
            }) => {
                use gradtac::calibrate::{ForceCalibration, GaugeSource};
                let method = gradtac::stages::force_model::CalibrationMethod::parse(&method).ok_or_else(|| {
                    gradtac::Error::Scene {
                        path: scene.clone(),
                        reason: format!("--method {method:?}: forward, placed, total, ridge, area or amplitude"),
                    }
                })?;
                let loaded = Scene::load(&scene)?;
                let index = gradtac::calibrate::calibration_sensor(&loaded, sensor.as_deref())?;
                let recording = loaded.resolve(loaded.sensors[index].source.path());
                let mut reads: Vec<(&str, &std::path::Path)> =
                    vec![("the scene", &scene), ("the recording", &recording)];
                reads.extend(force_file.as_deref().map(|f| ("the force file", f)));
                gradtac::guard::check_output_file(&out, &reads)?;
                let gauge = match force_file {
                    None => GaugeSource::SameCsv { column: force_column },
                    Some(path) => GaugeSource::File {
                        path,
                        column: force_column,
                        time_column: force_time_column,
                        time_unit: toml::Value::String(force_time_unit.clone()).try_into().map_err(|_| {
                            gradtac::Error::Scene {
                                path: scene.clone(),
                                reason: format!("--force-time-unit {force_time_unit:?}: s, ms, us or ns"),
                            }
                        })?,
                    },
                };
                let opts = ForceCalibration { sensor: Some(loaded.sensors[index].name.clone()), gauge, method };
                let (file, report) = gradtac::calibrate::calibrate_force(&loaded, &opts)?;
                gradtac::calibrate::write_json(&file, &out)?;
                if method != file.model.method() {
                    // the `forward` guard (force_model::calibrate): the identification failed
                    sayln!(
                        "note: the identified {} model predicted the calibration's presses, each held aside, worse \
                         than the {} law (with fewer than 3 presses: fitted its own frames worse), so the {} law was \
                         written (docs/force.md, the forward guard)",
                        method.name(),
                        file.model.method().name(),
                        file.model.method().name()
                    );
                }
                let c = &file.calibration;
                sayln!(
                    "calibrated {} force on {} frames in contact ({} read, {} with a gauge reading; {:.2}–{:.2} N): \
                     in-sample MAPE above 0.5 N {:.1} %; untouched frames above 0.5 N: {} of {} -> {}",
                    file.model.method().name(),
                    c.samples,
                    report.frames,
                    report.with_gauge,
                    c.force_range_n[0],
                    c.force_range_n[1],
                    c.in_sample_mape_pct,
                    report.untouched.1,
                    report.untouched.0,
                    out.display()
                );
                Ok(ExitCode::SUCCESS)
            }
            Some(CalibrateWhat::Baseline { scene, sensor, from, to, out }) => {
                let loaded = Scene::load(&scene)?;
                let index = gradtac::calibrate::calibration_sensor(&loaded, sensor.as_deref())?;
                let recording = loaded.resolve(loaded.sensors[index].source.path());
                gradtac::guard::check_output_file(&out, &[("the scene", &scene), ("the recording", &recording)])?;
                let tare = gradtac::calibrate::calibrate_baseline(&loaded, sensor.as_deref(), from, to)?;
                gradtac::calibrate::write_json(&tare, &out)?;
                let mean_noise = tare.noise.iter().sum::<f64>() / tare.noise.len() as f64;
                sayln!(
                    "baseline of sensor {} from {} untouched frames ({} taxels, mean noise {:.2}) -> {}",
                    tare.sensor,
                    tare.frames,
                    tare.taxels,
                    mean_noise,
                    out.display()
                );
                Ok(ExitCode::SUCCESS)
            }
        },
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
        Command::Demo {
            dir,
            quiet,
            #[cfg(feature = "view")]
            view,
        } => {
            let dir = match dir {
                Some(d) => d,
                None => demo::fresh_dir()?,
            };
            sayln!(
                "gradtac demo: a simulated two-finger grasp that slips ({}), at {} Hz",
                demo::DEMO_SLIP.name(),
                demo::RATE_HZ
            );
            #[cfg(feature = "view")]
            if let Some(rrd) = &view.view_save {
                let files = ["scene.toml", "recording.csv", "truth.csv", "out"].map(|n| dir.join(n));
                let named: Vec<(&str, &std::path::Path)> =
                    files.iter().map(|p| ("a file of the demo", p.as_path())).collect();
                gradtac::guard::check_output_file(rrd, &named)?;
            }
            #[allow(unused_mut)]
            let mut options = run::RunOptions { progress: !quiet, ..Default::default() };
            #[cfg(feature = "view")]
            let view = view.open(false)?;
            #[cfg(feature = "view")]
            {
                options.view = view.as_ref().map(gradtac::view::View::handle);
            }
            let report = demo::run_demo_with(&dir, &options);
            #[cfg(feature = "view")]
            {
                drop(options);
                finish_view(view, quiet)?;
            }
            let report = report?;
            say!("{report}");
            say!("{}", demo::where_lines(&report, &dir));
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `gradtac calibrate [dos] DIR -o m.json`.
fn calibrate_dos(args: DosArgs) -> Result<ExitCode, gradtac::Error> {
    let DosArgs {
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
        no_window,
        window_net,
        no_window_motion,
        window_trees,
        learned_out,
    } = args;
    // the trees are the default; the flag only names it
    let _ = window_trees;
    let (Some(data), Some(out)) = (data, out) else {
        return Err(gradtac::Error::Scene {
            path: PathBuf::from("gradtac calibrate"),
            reason: "give the labelled recordings' directory and --out (gradtac calibrate DIR -o model.json), \
                     or a subcommand: force, baseline, dos"
                .into(),
        });
    };
    let mut opts = gradtac::calibrate::CalibrateOptions {
        columns: columns.parse().map_err(gradtac::Error::Io2)?,
        rate_hz,
        shrinkage,
        student_t_dof: (!gaussian).then_some(student_t),
        mirror: !no_mirror,
        window: !no_window,
        window_motion: !no_window_motion,
        window_trees: !(window_net || no_window_motion),
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
    let mut model = gradtac::calibrate::calibrate_spans(&spans, &opts)?;
    if opts.window && opts.window_trees {
        let t = std::time::Instant::now();
        let recs = gradtac::calibrate::read_recordings(&data, &opts)?;
        let (part, choice) = gradtac::calibrate::calibrate_trees_part(&spans, &recs, &layout, &opts)?;
        let tally: Vec<String> = choice.weight_tally.iter().map(|(a, ok, n)| format!("a = {a}: {ok}/{n}")).collect();
        sayln!(
            "tree part ({} trees, {} nodes): weight by leave-one-object-out per recording ({}): a = {} ({:.1} s)",
            part.trees.trees().len(),
            part.trees.nodes(),
            if tally.is_empty() { "fewer than two objects, no choice".to_string() } else { tally.join(", ") },
            choice.weight,
            t.elapsed().as_secs_f64()
        );
        model = model.with_trees(Some(part))?;
    } else if opts.window {
        let t = std::time::Instant::now();
        let recs = gradtac::calibrate::read_recordings(&data, &opts)?;
        let (part, choice) = gradtac::calibrate::calibrate_window_part(&spans, &recs, &layout, &opts)?;
        if choice.weight_tally.is_empty() {
            sayln!(
                "window part: fewer than two objects, no leave-one-object-out choice: candidate {}, weight a = {}",
                choice.candidate,
                choice.weight
            );
        } else {
            let tally: Vec<String> =
                choice.weight_tally.iter().map(|(a, ok, n)| format!("a = {a}: {ok}/{n}")).collect();
            let candidate = if choice.candidate_accuracy.is_nan() {
                format!("candidate {} (the only one, no choice)", choice.candidate)
            } else {
                format!(
                    "candidate {} (leave-one-object-out {:.1} % per window)",
                    choice.candidate,
                    100.0 * choice.candidate_accuracy
                )
            };
            sayln!(
                "window part: {candidate}; weight by leave-one-object-out per recording ({}): a = {} ({:.1} s)",
                tally.join(", "),
                choice.weight,
                t.elapsed().as_secs_f64()
            );
        }
        model = model.with_window(Some(part))?;
    }
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

/// The recordings of `gradtac batch`: each argument is a path, or (when no such file exists
/// and it holds `*`, `?` or `[`) a glob pattern expanded in sorted order; a pattern that
/// matches no file is an error.
fn expand_recordings(args: &[String]) -> Result<Vec<PathBuf>, gradtac::Error> {
    let mut out = Vec::new();
    for a in args {
        let p = PathBuf::from(a);
        if p.exists() || !a.contains(['*', '?', '[']) {
            out.push(p);
            continue;
        }
        let bad = |reason: String| gradtac::Error::Scene { path: p.clone(), reason };
        let paths = glob::glob(a).map_err(|e| bad(format!("not a glob pattern: {e}")))?;
        let mut found = Vec::new();
        for entry in paths {
            let path = entry.map_err(|e| bad(format!("while expanding: {e}")))?;
            if path.is_file() {
                found.push(path);
            }
        }
        if found.is_empty() {
            return Err(bad("the pattern matches no file".into()));
        }
        found.sort();
        out.extend(found);
    }
    Ok(out)
}

/// Finish a view and say what it logged (on stderr when `quiet`).
#[cfg(feature = "view")]
fn finish_view(view: Option<gradtac::view::View>, quiet: bool) -> Result<(), gradtac::Error> {
    if let Some(v) = view {
        let report = v.finish()?;
        if report.dropped > 0 || !quiet {
            if quiet {
                eprint!("gradtac: {report}");
            } else {
                say!("{report}");
            }
        }
    }
    Ok(())
}
