//! The iterator and stream adapters agree, whatever the arrival pattern.

use futures::stream::{self, Stream, StreamExt};
use gradtac_stream::{
    merge_iter, merge_streams, IteratorStageExt, SensorId, Stage, StreamStageExt, TaxelFrame, Timestamp,
};
use proptest::prelude::*;
use std::pin::Pin;
use std::task::{Context, Poll};

/// Emits the sum of each pair of inputs; an odd one out is flushed by `finish`; a negative
/// input is an error.
#[derive(Default)]
struct PairSum(Option<i64>);
impl Stage for PairSum {
    type In = i64;
    type Out = i64;
    type Error = String;
    fn push(&mut self, x: i64, out: &mut Vec<i64>) -> Result<(), String> {
        if x < 0 {
            return Err(format!("negative input {x}"));
        }
        match self.0.take() {
            Some(h) => out.push(h + x),
            None => self.0 = Some(x),
        }
        Ok(())
    }
    fn finish(&mut self, out: &mut Vec<i64>) -> Result<(), String> {
        out.extend(self.0.take());
        Ok(())
    }
    fn reset(&mut self) {
        self.0 = None;
    }
}

/// A stream that returns `Pending` (waking itself) before items where `gaps` says so:
/// a stand-in for data arriving in arbitrary chunks.
struct Bursty<T> {
    items: std::vec::IntoIter<T>,
    gaps: Vec<bool>,
    k: usize,
    paused: bool,
}
impl<T: Unpin> Stream for Bursty<T> {
    type Item = T;
    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<T>> {
        let gap = self.gaps.get(self.k).copied().unwrap_or(false);
        if gap && !self.paused {
            self.paused = true;
            cx.waker().wake_by_ref();
            return Poll::Pending;
        }
        self.paused = false;
        self.k += 1;
        Poll::Ready(self.items.next())
    }
}

fn bursty<T>(items: Vec<T>, gaps: Vec<bool>) -> Bursty<T> {
    Bursty { items: items.into_iter(), gaps, k: 0, paused: false }
}

proptest! {
    #[test]
    fn stream_and_iterator_agree_in_any_chunking(
        xs in prop::collection::vec(-2i64..50, 0..40),
        gaps in prop::collection::vec(any::<bool>(), 0..40),
    ) {
        let it: Vec<Result<i64, String>> = xs.iter().copied().map(Ok).stage(PairSum::default()).collect();
        let st: Vec<Result<i64, String>> = futures::executor::block_on(
            bursty(xs.iter().copied().map(Ok).collect(), gaps).stage(PairSum::default()).collect(),
        );
        prop_assert_eq!(&it, &st);
        // after an error nothing else comes
        if let Some(p) = it.iter().position(|r| r.is_err()) {
            prop_assert_eq!(p, it.len() - 1);
        }
    }

    #[test]
    fn merged_streams_equal_merged_iterators_and_are_time_ordered(
        a in prop::collection::vec(0i64..1000, 0..30),
        b in prop::collection::vec(0i64..1000, 0..30),
        c in prop::collection::vec(0i64..1000, 0..30),
        gaps in prop::collection::vec(any::<bool>(), 0..30),
        cap in 1usize..5,
    ) {
        let mk = |name: &str, mut ts: Vec<i64>| {
            ts.sort();
            ts.into_iter().enumerate()
                .map(|(k, t)| Ok::<_, String>(TaxelFrame::new(SensorId::new(name), Timestamp(t), k as u64, vec![t as f64])))
                .collect::<Vec<_>>()
        };
        let srcs = vec![mk("a", a), mk("b", b), mk("c", c)];
        let total: usize = srcs.iter().map(Vec::len).sum();
        let via_iter: Vec<_> = merge_iter(srcs.iter().cloned().map(Vec::into_iter).collect(), cap).collect();
        let via_stream: Vec<_> = futures::executor::block_on(
            merge_streams(srcs.into_iter().map(|s| bursty(s, gaps.clone())).collect(), cap).collect::<Vec<_>>(),
        );
        prop_assert_eq!(&via_iter, &via_stream);
        prop_assert_eq!(via_iter.len(), total);
        let times: Vec<i64> = via_iter.iter().map(|r| r.as_ref().unwrap().time.0).collect();
        prop_assert!(times.windows(2).all(|w| w[0] <= w[1]), "{:?}", times);
    }
}

#[test]
fn an_error_ends_the_stream_once() {
    let out: Vec<_> = [Ok(1), Ok(2), Ok(-1), Ok(5), Ok(6)].into_iter().stage(PairSum::default()).collect();
    assert_eq!(out, vec![Ok(3), Err("negative input -1".to_string())]);
    let src_err: Vec<Result<i64, String>> =
        [Ok(1), Err("source broke".to_string()), Ok(2)].into_iter().stage(PairSum::default()).collect();
    assert_eq!(src_err, vec![Err("source broke".to_string())]);
}

#[test]
fn merge_surfaces_a_source_error_once() {
    let ok = |t| Ok::<_, String>(TaxelFrame::new(SensorId::new("a"), Timestamp(t), 0, vec![]));
    let a = vec![ok(1), ok(5)];
    let b = vec![ok(2), Err("bad line 3".to_string()), ok(9)];
    let out: Vec<_> = merge_iter(vec![a.into_iter(), b.into_iter()], 2).collect();
    assert_eq!(out.len(), 3);
    assert_eq!(out[2], Err("bad line 3".to_string()));
}

#[tokio::test]
async fn runs_on_tokio() {
    let s = stream::iter(vec![Ok::<_, String>(2), Ok(3)]).stage(PairSum::default());
    let v: Vec<_> = s.collect().await;
    assert_eq!(v, vec![Ok(5)]);
}

#[test]
fn items_before_a_source_error_are_not_lost() {
    let ok = |t| Ok::<_, String>(TaxelFrame::new(SensorId::new("a"), Timestamp(t), 0, vec![]));
    let src = vec![ok(1), ok(2), ok(3), Err("line 5".to_string())];
    let via_iter: Vec<_> = merge_iter(vec![src.clone().into_iter()], 16).collect();
    let via_stream: Vec<_> =
        futures::executor::block_on(merge_streams(vec![stream::iter(src)], 16).collect::<Vec<_>>());
    assert_eq!(via_iter, via_stream);
    assert_eq!(via_iter.len(), 4);
    assert_eq!(via_iter[3], Err("line 5".to_string()));
}
