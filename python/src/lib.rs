//! `gradtac._gradtac`: the compiled core of the `gradtac` Python package.
//!
//! The Python layer (`python/gradtac/__init__.py`) gives the friendly API; this module owns
//! the Rust calls. Every call that works releases the GIL (`Python::detach`), Arrow data
//! crosses to pyarrow over the Arrow C data interface (no per-row Python objects), and every
//! Rust error becomes a `gradtac.GradtacError` (or `FileNotFoundError` /
//! `PermissionError` for a missing or unreadable file) carrying the Rust message, which names
//! the file, line and key.

use arrow_array::RecordBatch;
use arrow_pyarrow::ToPyArrow;
use arrow_schema::SchemaRef;
use gradtac::memory::{MemoryOutputs, Pipeline as RustPipeline};
use gradtac::run::{RunOptions, RunReport};
use gradtac::stream::Timestamp;
use gradtac::{Plan, Scene as RustScene};
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyFileNotFoundError, PyPermissionError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::path::PathBuf;
use std::sync::mpsc::Receiver;
use std::sync::Mutex;
use std::thread::JoinHandle;

create_exception!(
    _gradtac,
    GradtacError,
    PyException,
    "An error of gradtac: a bad scene or setting, unreadable input, a stage error. The message is the Rust \
     library's, naming the file, line and key."
);

/// The innermost I/O error of a gradtac error, if any.
fn io_kind(e: &(dyn std::error::Error + 'static)) -> Option<std::io::ErrorKind> {
    let mut cur: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(c) = cur {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            return Some(io.kind());
        }
        cur = c.source();
    }
    None
}

/// A gradtac error as a Python exception with the Rust message.
fn py_err(e: gradtac::Error) -> PyErr {
    let msg = e.to_string();
    match io_kind(&e) {
        Some(std::io::ErrorKind::NotFound) => PyFileNotFoundError::new_err(msg),
        Some(std::io::ErrorKind::PermissionDenied) => PyPermissionError::new_err(msg),
        _ => GradtacError::new_err(msg),
    }
}

/// A Python value (dict / list / str / int / float / bool / path) as a TOML value.
fn to_toml(v: &Bound<'_, PyAny>, at: &str) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        let i: i64 = v.extract().map_err(|_| PyValueError::new_err(format!("{at}: integer out of range")))?;
        return Ok(toml::Value::Integer(i));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, val) in d.iter() {
            let k: String =
                k.extract().map_err(|_| PyValueError::new_err(format!("{at}: keys of a scene dict are strings")))?;
            let path = if at.is_empty() { k.clone() } else { format!("{at}.{k}") };
            if val.is_none() {
                continue;
            }
            t.insert(k, to_toml(&val, &path)?);
        }
        return Ok(toml::Value::Table(t));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items = v
            .try_iter()?
            .enumerate()
            .map(|(i, x)| to_toml(&x?, &format!("{at}[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(toml::Value::Array(items));
    }
    // os.PathLike (pathlib.Path) and NumPy scalars
    let py = v.py();
    if let Ok(p) = py.import("os").and_then(|os| os.call_method1("fspath", (v,))) {
        return Ok(toml::Value::String(p.extract()?));
    }
    if let Ok(x) = v.call_method0("item") {
        return to_toml(&x, at);
    }
    Err(PyValueError::new_err(format!("{at}: cannot put a {} into a scene", v.get_type().name()?)))
}

/// A parsed scene.
#[pyclass(module = "gradtac._gradtac", frozen)]
struct Scene {
    inner: RustScene,
}

#[pymethods]
impl Scene {
    /// Read a scene file (relative paths resolve against its directory).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
        let inner = py.detach(|| RustScene::load(&path)).map_err(py_err)?;
        Ok(Scene { inner })
    }

    /// Parse TOML text; relative paths resolve against `base_dir` (default: the working
    /// directory); `origin` is the scene file errors name (and no output may replace).
    #[staticmethod]
    #[pyo3(signature = (text, base_dir=None, origin=None))]
    fn from_toml(text: &str, base_dir: Option<PathBuf>, origin: Option<PathBuf>) -> PyResult<Scene> {
        let base = base_dir.unwrap_or_else(|| std::env::current_dir().unwrap_or_default());
        let origin = origin.unwrap_or_else(|| PathBuf::from("<scene>"));
        let inner = RustScene::from_toml(text, base, &origin).map_err(py_err)?;
        Ok(Scene { inner })
    }

    /// The directory relative paths resolve against.
    #[getter]
    fn base_dir(&self) -> PathBuf {
        self.inner.base_dir.clone()
    }

    /// The scene file it was read from (`<scene>` for text and dicts).
    #[getter]
    fn origin(&self) -> PathBuf {
        self.inner.origin.clone()
    }

    /// Pickled as its text, base directory and origin (Ray ships scenes to workers so).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String, PathBuf, PathBuf))> {
        let me = slf.get();
        let ctor = slf.get_type().getattr("from_toml")?;
        Ok((ctor, (me.inner.text.clone(), me.inner.base_dir.clone(), me.inner.origin.clone())))
    }

    /// Check that `recordings` can be batched with this scene (`gradtac batch`'s checks, before
    /// anything runs): the scene reads one file, its outputs have distinct table names, and no
    /// two recordings share a file stem.
    fn check_batch(&self, recordings: Vec<PathBuf>) -> PyResult<()> {
        gradtac::batch::check_stems(&recordings).map_err(py_err)?;
        gradtac::batch::check_batchable(&self.inner).map_err(py_err)
    }

    /// The archive's table name of each output (the file stem of its path).
    #[getter]
    fn output_names(&self) -> PyResult<Vec<String>> {
        gradtac::batch::output_names(&self.inner).map_err(py_err)
    }

    /// Run the scene on one recording into the batch archive under `out`
    /// (`gradtac::batch::run_recording`: `<out>/<output>/recording=<stem>/sensor=<name>/part-000000.parquet`,
    /// exactly as `gradtac batch` writes it); returns `{"recording", "frames", "files"}`.
    fn run_recording<'py>(&self, py: Python<'py>, recording: PathBuf, out: PathBuf) -> PyResult<Bound<'py, PyDict>> {
        let scene = &self.inner;
        let s = py.detach(|| gradtac::batch::run_recording(scene, &recording, &out)).map_err(py_err)?;
        let d = PyDict::new(py);
        d.set_item("recording", s.recording.display().to_string())?;
        d.set_item("frames", s.frames)?;
        d.set_item("files", s.files.iter().map(|p| p.display().to_string()).collect::<Vec<_>>())?;
        Ok(d)
    }

    /// `gradtac batch` in this process: every recording on a pool of `jobs` threads (0: the
    /// available cores); returns `{"done": [...], "failed": [(recording, message)], "seconds", "jobs"}`.
    #[pyo3(signature = (recordings, out, jobs=0))]
    fn run_batch<'py>(
        &self,
        py: Python<'py>,
        recordings: Vec<PathBuf>,
        out: PathBuf,
        jobs: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let scene = &self.inner;
        let opts = gradtac::batch::BatchOptions { jobs, progress: false };
        let r = py.detach(|| gradtac::batch::run_batch(scene, &recordings, &out, &opts)).map_err(py_err)?;
        let d = PyDict::new(py);
        let done = PyList::empty(py);
        for s in &r.done {
            let x = PyDict::new(py);
            x.set_item("recording", s.recording.display().to_string())?;
            x.set_item("frames", s.frames)?;
            x.set_item("files", s.files.iter().map(|p| p.display().to_string()).collect::<Vec<_>>())?;
            done.append(x)?;
        }
        d.set_item("done", done)?;
        let failed: Vec<(String, String)> =
            r.failed.iter().map(|(p, e)| (p.display().to_string(), e.to_string())).collect();
        d.set_item("failed", failed)?;
        d.set_item("skipped", r.skipped)?;
        d.set_item("seconds", r.seconds)?;
        d.set_item("jobs", r.jobs)?;
        Ok(d)
    }

    /// A scene from a dict of the TOML's structure (`{"sensor": [...], "stages": {...}, "output": [...]}`).
    #[staticmethod]
    #[pyo3(signature = (scene, base_dir=None))]
    fn from_dict(scene: &Bound<'_, PyDict>, base_dir: Option<PathBuf>) -> PyResult<Scene> {
        let text = dict_to_toml(scene)?;
        Scene::from_toml(&text, base_dir, None)
    }

    /// The TOML text (stored in every output's metadata).
    #[getter]
    fn text(&self) -> &str {
        &self.inner.text
    }

    /// The outputs as (tap, path as written in the scene) pairs, in order.
    #[getter]
    fn outputs(&self) -> Vec<(String, String)> {
        self.inner.outputs.iter().map(|o| (o.tap.clone(), o.path.display().to_string())).collect()
    }

    /// The sensors' names.
    #[getter]
    fn sensors(&self) -> Vec<String> {
        self.inner.sensors.iter().map(|s| s.name.clone()).collect()
    }

    /// The plan as `gradtac explain` prints it.
    fn explain(&self, py: Python<'_>) -> PyResult<String> {
        let scene = &self.inner;
        py.detach(|| Plan::new(scene).map(|p| p.explain(scene))).map_err(py_err)
    }

    /// Run and write the outputs exactly as `gradtac run` does; returns what was written.
    fn run_write<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let scene = &self.inner;
        let report = py
            .detach(|| {
                let plan = Plan::new(scene)?;
                gradtac::run::run_blocking(scene, &plan, &RunOptions { progress: false, threads: 0 })
            })
            .map_err(py_err)?;
        report_dict(py, &report)
    }

    /// Run in memory; an iterator of (output index, pyarrow.RecordBatch).
    #[pyo3(signature = (capacity=4))]
    fn run_batches(&self, py: Python<'_>, capacity: usize) -> PyResult<RunIter> {
        let scene = self.inner.clone();
        let plan = py.detach(|| Plan::new(&scene)).map_err(py_err)?;
        let (out, rx) = MemoryOutputs::channel(capacity);
        let n = scene.outputs.len();
        let handle = std::thread::Builder::new()
            .name("gradtac-run".into())
            .spawn(move || {
                let report = gradtac::memory::run(&scene, &plan, &out);
                let schemas = (0..n).map(|i| out.schema(i)).collect();
                drop(out);
                report.map(|r| (r, schemas))
            })
            .map_err(|e| GradtacError::new_err(format!("cannot start the run's thread: {e}")))?;
        Ok(RunIter { state: Mutex::new(IterState { rx: Some(rx), handle: Some(handle), schemas: Vec::new() }) })
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(sensors={:?}, outputs={:?})",
            self.inner.sensors.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(),
            self.inner.outputs.iter().map(|o| o.path.display().to_string()).collect::<Vec<_>>()
        )
    }
}

fn dict_to_toml(d: &Bound<'_, PyDict>) -> PyResult<String> {
    let v = to_toml(d.as_any(), "")?;
    toml::to_string(&v).map_err(|e| PyValueError::new_err(format!("scene dict: {e}")))
}

fn report_dict<'py>(py: Python<'py>, r: &RunReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("frames", r.frames.to_vec())?;
    let outputs: Vec<(Vec<String>, u64)> =
        r.outputs.iter().map(|(p, n)| (p.iter().map(|p| p.display().to_string()).collect(), *n)).collect();
    d.set_item("outputs", outputs)?;
    d.set_item("buses", r.buses.clone())?;
    d.set_item("seconds", r.seconds)?;
    d.set_item("interrupted", r.interrupted)?;
    Ok(d)
}

type RunResult = Result<(RunReport, Vec<Option<SchemaRef>>), gradtac::Error>;

struct IterState {
    rx: Option<Receiver<(usize, RecordBatch)>>,
    handle: Option<JoinHandle<RunResult>>,
    schemas: Vec<Option<SchemaRef>>,
}

/// The batches of an in-memory run, as they are made (the run goes on in a thread of its
/// own, at most a few batches ahead).
#[pyclass(module = "gradtac._gradtac")]
struct RunIter {
    state: Mutex<IterState>,
}

impl RunIter {
    fn lock(&self) -> std::sync::MutexGuard<'_, IterState> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

#[pymethods]
impl RunIter {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&self, py: Python<'_>) -> PyResult<Option<(usize, Py<PyAny>)>> {
        // never wait with the GIL released while holding the lock (another thread holding
        // the GIL could wait for the lock): take the receiver out, wait, put it back
        let taken = self.lock().rx.take();
        let Some(rx) = taken else { return Ok(None) };
        let (rx, got) = py.detach(move || {
            let got = rx.recv();
            (rx, got)
        });
        match got {
            Ok((i, batch)) => {
                self.lock().rx = Some(rx);
                Ok(Some((i, batch.to_pyarrow(py)?.unbind())))
            }
            Err(_) => {
                drop(rx);
                let taken = self.lock().handle.take();
                let Some(handle) = taken else { return Ok(None) };
                let joined = py.detach(|| handle.join());
                match joined {
                    Ok(Ok((_, schemas))) => {
                        self.lock().schemas = schemas;
                        Ok(None)
                    }
                    Ok(Err(e)) => Err(py_err(e)),
                    Err(_) => Err(GradtacError::new_err("the run panicked (a bug: please report it)")),
                }
            }
        }
    }

    /// The schema of output `index` (after the run, or None when it never opened).
    fn schema(&self, py: Python<'_>, index: usize) -> PyResult<Option<Py<PyAny>>> {
        let st = self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        match st.schemas.get(index).cloned().flatten() {
            Some(s) => Ok(Some(s.as_ref().clone().to_pyarrow(py)?.unbind())),
            None => Ok(None),
        }
    }
}

impl Drop for RunIter {
    fn drop(&mut self) {
        // hang up first: the run's next batch fails and it ends (no file to clean up)
        let st = self.state.get_mut().unwrap_or_else(std::sync::PoisonError::into_inner);
        st.rx = None;
        if let Some(h) = st.handle.take() {
            let _ = h.join();
        }
    }
}

/// A streaming single-sensor chain (see `gradtac.Pipeline`).
#[pyclass(module = "gradtac._gradtac")]
struct Pipeline {
    inner: Mutex<RustPipeline>,
}

impl Pipeline {
    fn with<R: Send>(&self, py: Python<'_>, f: impl FnOnce(&mut RustPipeline) -> R + Send) -> R {
        py.detach(|| f(&mut self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner)))
    }
}

fn batch_out(py: Python<'_>, b: Result<RecordBatch, gradtac::Error>) -> PyResult<Py<PyAny>> {
    Ok(b.map_err(py_err)?.to_pyarrow(py)?.unbind())
}

fn c_slice<'a, T: numpy::Element>(a: &'a PyReadonlyArray2<'_, T>) -> PyResult<&'a [T]> {
    a.as_slice().map_err(|_| PyValueError::new_err("values must be C-contiguous (numpy.ascontiguousarray)"))
}

#[pymethods]
impl Pipeline {
    #[new]
    #[pyo3(signature = (layout="biotac-sp", tap="track", settings=None, rate_hz=None, sensor="sensor"))]
    fn new(
        layout: &str,
        tap: &str,
        settings: Option<&Bound<'_, PyDict>>,
        rate_hz: Option<f64>,
        sensor: &str,
    ) -> PyResult<Pipeline> {
        let table = match settings {
            Some(d) => match to_toml(d.as_any(), "settings")? {
                toml::Value::Table(t) => t,
                _ => unreachable!("a dict gives a table"),
            },
            None => toml::Table::new(),
        };
        let inner = RustPipeline::new(layout, tap, &table, rate_hz, sensor).map_err(py_err)?;
        Ok(Pipeline { inner: Mutex::new(inner) })
    }

    /// Taxels per frame.
    #[getter]
    fn taxels(&self) -> usize {
        self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner).taxels()
    }

    /// The pyarrow schema of every batch.
    #[getter]
    fn schema(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let s = self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner).schema();
        Ok(s.as_ref().clone().to_pyarrow(py)?.unbind())
    }

    /// The one-sensor scene the pipeline runs (TOML).
    #[getter]
    fn scene(&self) -> String {
        self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner).scene_text().to_string()
    }

    /// Each stage's effective settings, as `gradtac explain` prints them.
    fn explain(&self) -> String {
        self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner).explain()
    }

    /// Push frames timed in int64 nanoseconds; values float64 (frames × taxels), C-contiguous.
    fn push_ns(
        &self,
        py: Python<'_>,
        times: PyReadonlyArray1<'_, i64>,
        values: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Py<PyAny>> {
        let t = times.as_slice().map_err(|_| PyValueError::new_err("times must be contiguous"))?;
        let v = c_slice(&values)?;
        let b = self.with(py, |p| p.push_frames(t, v));
        batch_out(py, b)
    }

    /// Push frames timed in float64 seconds (rounded to the nanosecond, as sources do).
    fn push_s(
        &self,
        py: Python<'_>,
        times: PyReadonlyArray1<'_, f64>,
        values: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Py<PyAny>> {
        let t = times.as_slice().map_err(|_| PyValueError::new_err("times must be contiguous"))?;
        let ns = t
            .iter()
            .enumerate()
            .map(|(i, &s)| {
                Timestamp::from_secs_f64(s)
                    .map(|t| t.0)
                    .ok_or_else(|| PyValueError::new_err(format!("times[{i}] = {s} s is not a finite time in i64 ns")))
            })
            .collect::<PyResult<Vec<i64>>>()?;
        let v = c_slice(&values)?;
        let b = self.with(py, |p| p.push_frames(&ns, v));
        batch_out(py, b)
    }

    /// Push frames timed by the pipeline's rate_hz.
    fn push_at_rate(&self, py: Python<'_>, values: PyReadonlyArray2<'_, f64>) -> PyResult<Py<PyAny>> {
        let v = c_slice(&values)?;
        let b = self.with(py, |p| p.push_frames_at_rate(v));
        batch_out(py, b)
    }

    /// End of stream: the last records; the pipeline starts afresh.
    fn finish(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let b = self.with(py, |p| p.finish());
        batch_out(py, b)
    }

    /// Drop every stage's state (a gap): the next push starts a new stream.
    fn reset(&self, py: Python<'_>) -> PyResult<()> {
        self.with(py, |p| p.reset()).map_err(py_err)
    }
}

/// Benchmark support (`python/bench/push_overhead.py`): push `values` (frames × taxels, at
/// 100 Hz) through a fresh `gradtac::memory::Pipeline` in batches of `batch` frames, in Rust
/// alone, `repeats` times; returns (median ns per frame, records out).
#[pyfunction]
fn _bench_rust_push(
    py: Python<'_>,
    values: PyReadonlyArray2<'_, f64>,
    tap: &str,
    batch: usize,
    repeats: usize,
) -> PyResult<(f64, usize)> {
    let taxels = values.as_array().ncols();
    let v = c_slice(&values)?;
    let frames = v.len() / taxels.max(1);
    let times: Vec<i64> = (0..frames as i64).map(|k| k * 10_000_000).collect();
    let run = || -> Result<(f64, usize), gradtac::Error> {
        let mut per_frame = Vec::with_capacity(repeats.max(1));
        let mut rows = 0;
        for _ in 0..repeats.max(1) {
            let mut p = RustPipeline::new("biotac-sp", tap, &toml::Table::new(), Some(100.0), "ff")?;
            rows = 0;
            let start = std::time::Instant::now();
            for (t, x) in times.chunks(batch.max(1)).zip(v.chunks(batch.max(1) * taxels)) {
                rows += std::hint::black_box(p.push_frames(t, x)?).num_rows();
            }
            rows += p.finish()?.num_rows();
            per_frame.push(start.elapsed().as_nanos() as f64 / frames.max(1) as f64);
        }
        per_frame.sort_by(f64::total_cmp);
        Ok((per_frame[per_frame.len() / 2], rows))
    };
    py.detach(run).map_err(py_err)
}

/// The compiled core of gradtac.
#[pymodule]
fn _gradtac(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<RunIter>()?;
    m.add_class::<Pipeline>()?;
    m.add_function(wrap_pyfunction!(_bench_rust_push, m)?)?;
    m.add("GradtacError", m.py().get_type::<GradtacError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
