//! The synchronous stage abstraction.

use std::ops::Add;

/// How far a stage's output lags its input.
///
/// `frames` counts input samples an output waits for (a centred Savitzky–Golay filter of
/// window `w` waits `(w−1)/2` frames); `nanos` counts time (a window of a duration). Delays of
/// a chain add up: [`Stage::delay`] of [`Chain`] is the sum, which `gradtac explain` reports
/// as the pipeline's latency.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Delay {
    /// Delay in input frames.
    pub frames: u64,
    /// Delay in nanoseconds.
    pub nanos: i64,
}

impl Delay {
    /// No delay.
    pub const ZERO: Delay = Delay { frames: 0, nanos: 0 };

    /// A delay of `n` frames.
    pub const fn frames(n: u64) -> Self {
        Delay { frames: n, nanos: 0 }
    }

    /// A delay of `ns` nanoseconds.
    pub const fn nanos(ns: i64) -> Self {
        Delay { frames: 0, nanos: ns }
    }

    /// The delay in seconds at a sample rate (frames become `frames / rate_hz`).
    pub fn seconds_at(&self, rate_hz: f64) -> f64 {
        self.frames as f64 / rate_hz + self.nanos as f64 * 1e-9
    }
}

impl Add for Delay {
    type Output = Delay;
    fn add(self, o: Delay) -> Delay {
        Delay { frames: self.frames + o.frames, nanos: self.nanos + o.nanos }
    }
}

/// One step of a pipeline as a synchronous state machine.
///
/// A stage takes one input at a time ([`push`](Stage::push)) and appends zero or more
/// outputs to `out`; at the end of a stream [`finish`](Stage::finish) appends what it still
/// holds; [`reset`](Stage::reset) forgets history at a discontinuity (a gap in time, a new
/// recording). It needs no executor: drive it by hand, over an [`Iterator`] with
/// [`IteratorStageExt::stage`](crate::IteratorStageExt::stage), or over a
/// [`futures::Stream`] with [`StreamStageExt::stage`](crate::StreamStageExt::stage).
///
/// Input and output are types, so stages compose only in an order that makes sense; a
/// chain in the wrong order does not compile:
///
/// ```compile_fail
/// use gradtac_stream::{Stage, StageExt, TaxelFrame};
/// # struct Events; struct Event;
/// # impl Stage for Events { type In = TaxelFrame; type Out = Event; type Error = std::convert::Infallible;
/// #   fn push(&mut self, _: TaxelFrame, _: &mut Vec<Event>) -> Result<(), Self::Error> { Ok(()) } fn reset(&mut self) {} }
/// # struct Smooth;
/// # impl Stage for Smooth { type In = TaxelFrame; type Out = TaxelFrame; type Error = std::convert::Infallible;
/// #   fn push(&mut self, f: TaxelFrame, o: &mut Vec<TaxelFrame>) -> Result<(), Self::Error> { o.push(f); Ok(()) } fn reset(&mut self) {} }
/// // events come out of `Events`; `Smooth` wants frames: this is a type error.
/// let pipeline = Events.then(Smooth);
/// ```
///
/// while the right order compiles:
///
/// ```
/// use gradtac_stream::{Stage, StageExt, TaxelFrame};
/// # struct Events; struct Event;
/// # impl Stage for Events { type In = TaxelFrame; type Out = Event; type Error = std::convert::Infallible;
/// #   fn push(&mut self, _: TaxelFrame, _: &mut Vec<Event>) -> Result<(), Self::Error> { Ok(()) } fn reset(&mut self) {} }
/// # struct Smooth;
/// # impl Stage for Smooth { type In = TaxelFrame; type Out = TaxelFrame; type Error = std::convert::Infallible;
/// #   fn push(&mut self, f: TaxelFrame, o: &mut Vec<TaxelFrame>) -> Result<(), Self::Error> { o.push(f); Ok(()) } fn reset(&mut self) {} }
/// let pipeline = Smooth.then(Events);
/// ```
pub trait Stage {
    /// What the stage consumes.
    type In;
    /// What it produces.
    type Out;
    /// What can go wrong on bad input.
    type Error;

    /// Consume one input, appending zero or more outputs to `out`. On `Err` the stage's
    /// state is unspecified until [`reset`](Stage::reset); adapters end the stream.
    fn push(&mut self, input: Self::In, out: &mut Vec<Self::Out>) -> Result<(), Self::Error>;

    /// End of stream: append whatever is still held (a centred filter's last half window).
    /// After `finish` the stage behaves as if [`reset`](Stage::reset).
    fn finish(&mut self, out: &mut Vec<Self::Out>) -> Result<(), Self::Error> {
        let _ = out;
        self.reset();
        Ok(())
    }

    /// Forget all history (a discontinuity); configuration is kept.
    fn reset(&mut self);

    /// How far output lags input (see [`Delay`]).
    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

/// Composition of stages; implemented for every [`Stage`].
pub trait StageExt: Stage + Sized {
    /// Run `next` on every output of `self`. Errors of both sides become `crate::Error`.
    fn then<B>(self, next: B) -> Chain<Self, B>
    where
        B: Stage<In = Self::Out>,
    {
        Chain { first: self, second: next, buf: Vec::new() }
    }

    /// Push every input of an iterator and finish, collecting all outputs: the offline
    /// one-shot form of a stage.
    fn run_all<I>(&mut self, inputs: I) -> Result<Vec<Self::Out>, Self::Error>
    where
        I: IntoIterator<Item = Self::In>,
    {
        let mut out = Vec::new();
        for x in inputs {
            self.push(x, &mut out)?;
        }
        self.finish(&mut out)?;
        Ok(out)
    }
}

impl<S: Stage> StageExt for S {}

/// Two stages in series: see [`StageExt::then`].
#[derive(Debug, Clone)]
#[must_use = "a chain does nothing until inputs are pushed"]
pub struct Chain<A: Stage, B> {
    first: A,
    second: B,
    buf: Vec<A::Out>,
}

impl<A: Stage, B> Chain<A, B> {
    /// The two stages.
    pub fn parts(&self) -> (&A, &B) {
        (&self.first, &self.second)
    }
}

impl<A, B> Stage for Chain<A, B>
where
    A: Stage,
    B: Stage<In = A::Out>,
    A::Error: Into<crate::Error>,
    B::Error: Into<crate::Error>,
{
    type In = A::In;
    type Out = B::Out;
    type Error = crate::Error;

    fn push(&mut self, input: A::In, out: &mut Vec<B::Out>) -> Result<(), crate::Error> {
        self.first.push(input, &mut self.buf).map_err(Into::into)?;
        for x in self.buf.drain(..) {
            self.second.push(x, out).map_err(Into::into)?;
        }
        Ok(())
    }

    fn finish(&mut self, out: &mut Vec<B::Out>) -> Result<(), crate::Error> {
        self.first.finish(&mut self.buf).map_err(Into::into)?;
        for x in self.buf.drain(..) {
            self.second.push(x, out).map_err(Into::into)?;
        }
        self.second.finish(out).map_err(Into::into)
    }

    fn reset(&mut self) {
        self.buf.clear();
        self.first.reset();
        self.second.reset();
    }

    fn delay(&self) -> Delay {
        self.first.delay() + self.second.delay()
    }
}

/// A stage from a function of one input: a stateless map (for glue in custom pipelines).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct MapStage<F, I, O> {
    f: F,
    _types: std::marker::PhantomData<fn(I) -> O>,
}

/// A stateless stage that maps each input to one output.
pub fn map_stage<I, O, F: FnMut(I) -> O>(f: F) -> MapStage<F, I, O> {
    MapStage { f, _types: std::marker::PhantomData }
}

impl<I, O, F: FnMut(I) -> O> Stage for MapStage<F, I, O> {
    type In = I;
    type Out = O;
    type Error = std::convert::Infallible;
    fn push(&mut self, input: I, out: &mut Vec<O>) -> Result<(), Self::Error> {
        out.push((self.f)(input));
        Ok(())
    }
    fn reset(&mut self) {}
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Emits the running sum every second input; holds the odd one until finish.
    struct PairSum {
        held: Option<i64>,
    }
    impl Stage for PairSum {
        type In = i64;
        type Out = i64;
        type Error = std::convert::Infallible;
        fn push(&mut self, x: i64, out: &mut Vec<i64>) -> Result<(), Self::Error> {
            match self.held.take() {
                Some(h) => out.push(h + x),
                None => self.held = Some(x),
            }
            Ok(())
        }
        fn finish(&mut self, out: &mut Vec<i64>) -> Result<(), Self::Error> {
            out.extend(self.held.take());
            Ok(())
        }
        fn reset(&mut self) {
            self.held = None;
        }
        fn delay(&self) -> Delay {
            Delay::frames(1)
        }
    }

    #[test]
    fn chain_flushes_both_sides_and_adds_delays() {
        let mut c = PairSum { held: None }.then(PairSum { held: None });
        assert_eq!(c.delay(), Delay::frames(2));
        assert_eq!(c.run_all([1, 2, 3, 4, 5]).unwrap(), vec![10, 5]);
        // finish left it reset: a second run starts clean
        assert_eq!(c.run_all([1, 1]).unwrap(), vec![2]);
    }

    #[test]
    fn map_stage_maps() {
        let mut m = map_stage(|x: i32| x * 2);
        assert_eq!(m.run_all([1, 2]).unwrap(), vec![2, 4]);
    }
}
