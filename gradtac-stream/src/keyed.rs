//! One stage state per sensor.

use crate::{Delay, HasSensor, SensorId, Stage};

/// Runs one instance of a stage per sensor, created on the sensor's first input.
///
/// Inputs are routed by [`HasSensor::sensor`]. `finish` and `reset` reach every instance, in
/// the order sensors were first seen (so output order is deterministic). Lookup is a linear
/// scan with a pointer-equality fast path: a hand has at most a handful of sensors, where
/// this beats hashing.
///
/// ```
/// use gradtac_stream::{map_stage, Keyed, SensorId, StageExt, TaxelFrame, Timestamp};
/// let mut per_sensor = Keyed::new(|_sensor: &SensorId| map_stage(|f: TaxelFrame| f.values[0]));
/// let f = |s: &str, v| TaxelFrame::new(SensorId::new(s), Timestamp(0), 0, vec![v]);
/// assert_eq!(per_sensor.run_all([f("ff", 1.0), f("th", 2.0)]).unwrap(), vec![1.0, 2.0]);
/// assert_eq!(per_sensor.sensors().count(), 2);
/// ```
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct Keyed<S, F> {
    make: F,
    states: Vec<(SensorId, S)>,
    last: usize,
}

impl<S, F> Keyed<S, F>
where
    S: Stage,
    F: FnMut(&SensorId) -> S,
{
    /// A keyed stage whose instances `make` builds, given the sensor.
    pub fn new(make: F) -> Self {
        Keyed { make, states: Vec::new(), last: 0 }
    }

    /// The sensors seen so far, in order of first sight.
    ///
    /// (See also [`Keyed::cloning`] for the common case of one configured prototype.)
    pub fn sensors(&self) -> impl Iterator<Item = &SensorId> {
        self.states.iter().map(|(k, _)| k)
    }

    /// The instance of one sensor, if it has been seen.
    pub fn get(&self, sensor: &str) -> Option<&S> {
        self.states.iter().find(|(k, _)| k.as_str() == sensor).map(|(_, s)| s)
    }

    /// Reset one sensor's instance (a gap on that sensor only).
    pub fn reset_sensor(&mut self, sensor: &str) {
        if let Some((_, s)) = self.states.iter_mut().find(|(k, _)| k.as_str() == sensor) {
            s.reset();
        }
    }

    fn index(&mut self, key: &SensorId) -> usize {
        if let Some((k, _)) = self.states.get(self.last) {
            if k.ptr_eq(key) || k == key {
                return self.last;
            }
        }
        let i = match self.states.iter().position(|(k, _)| k.ptr_eq(key) || k == key) {
            Some(i) => i,
            None => {
                let s = (self.make)(key);
                self.states.push((key.clone(), s));
                self.states.len() - 1
            }
        };
        self.last = i;
        i
    }
}

impl<S: Stage + Clone> Keyed<S, Box<dyn FnMut(&SensorId) -> S + Send>> {
    /// A keyed stage whose per-sensor instances are clones of `prototype` (a configured,
    /// fresh stage).
    ///
    /// ```
    /// use gradtac_stream::{map_stage, Keyed, SensorId, StageExt, TaxelFrame, Timestamp};
    /// let mut per_sensor = Keyed::cloning(map_stage(|f: TaxelFrame| f.values[0] * 2.0));
    /// let f = |s: &str, v| TaxelFrame::new(SensorId::new(s), Timestamp(0), 0, vec![v]);
    /// assert_eq!(per_sensor.run_all([f("ff", 1.0), f("th", 2.0), f("ff", 3.0)]).unwrap(), vec![2.0, 4.0, 6.0]);
    /// assert_eq!(per_sensor.sensors().count(), 2);
    /// ```
    pub fn cloning(prototype: S) -> Self
    where
        S: Send + 'static,
    {
        Keyed::new(Box::new(move |_: &SensorId| prototype.clone()))
    }
}

impl<S, F> Stage for Keyed<S, F>
where
    S: Stage,
    S::In: HasSensor,
    F: FnMut(&SensorId) -> S,
{
    type In = S::In;
    type Out = S::Out;
    type Error = S::Error;

    fn push(&mut self, input: S::In, out: &mut Vec<S::Out>) -> Result<(), S::Error> {
        let i = self.index(input.sensor());
        self.states[i].1.push(input, out)
    }

    fn finish(&mut self, out: &mut Vec<S::Out>) -> Result<(), S::Error> {
        for (_, s) in &mut self.states {
            s.finish(out)?;
        }
        Ok(())
    }

    fn reset(&mut self) {
        for (_, s) in &mut self.states {
            s.reset();
        }
    }

    /// The largest delay among the instances (zero before any input).
    fn delay(&self) -> Delay {
        self.states
            .iter()
            .map(|(_, s)| s.delay())
            .fold(Delay::ZERO, |a, d| Delay { frames: a.frames.max(d.frames), nanos: a.nanos.max(d.nanos) })
    }
}
