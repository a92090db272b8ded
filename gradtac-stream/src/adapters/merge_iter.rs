//! Time-ordered merge of iterators.

use crate::merge::MergeCore;
use crate::Timed;

/// Iterator returned by [`merge_iter`].
#[must_use = "iterators are lazy and do nothing unless consumed"]
pub struct MergeIter<I, T, E> {
    sources: Vec<I>,
    core: MergeCore<T>,
    /// A source's error, held until the items that source delivered before it are out.
    error: Option<(usize, E)>,
    failed: bool,
}

/// Merge iterators of time-ordered `Result` items into one time-ordered iterator, queueing
/// at most `capacity` items per source (see [`crate::merge`] for the order rule). The first
/// error of any source is yielded once, then the merge ends; the items that source delivered
/// before its error (and whatever the order rule releases before them) come out first.
///
/// ```
/// use gradtac_stream::{merge_iter, TaxelFrame, SensorId, Timestamp};
/// let f = |s: &str, t| Ok::<_, ()>(TaxelFrame::new(SensorId::new(s), Timestamp(t), 0, vec![]));
/// let a = vec![f("ff", 0), f("ff", 20)].into_iter();
/// let b = vec![f("th", 10), f("th", 30)].into_iter();
/// let times: Vec<i64> = merge_iter(vec![a, b], 4).map(|r| r.unwrap().time.0).collect();
/// assert_eq!(times, [0, 10, 20, 30]);
/// ```
pub fn merge_iter<I, T, E>(sources: Vec<I>, capacity: usize) -> MergeIter<I, T, E>
where
    I: Iterator<Item = Result<T, E>>,
    T: Timed,
{
    let core = MergeCore::new(sources.len(), capacity);
    MergeIter { sources, core, error: None, failed: false }
}

impl<I, T, E> Iterator for MergeIter<I, T, E>
where
    I: Iterator<Item = Result<T, E>>,
    T: Timed,
{
    type Item = Result<T, E>;

    fn next(&mut self) -> Option<Result<T, E>> {
        if self.failed {
            return None;
        }
        loop {
            if let Some(x) = self.core.pop_ready() {
                return Some(Ok(x));
            }
            if self.core.is_done() {
                return None;
            }
            if self.error.as_ref().is_some_and(|(i, _)| self.core.starved(*i)) {
                self.failed = true;
                return self.error.take().map(|(_, e)| Err(e));
            }
            // Fill the starved sources (one item each is all the order rule needs).
            for i in 0..self.sources.len() {
                if self.core.starved(i) {
                    match self.sources[i].next() {
                        Some(Ok(x)) => self.core.push(i, x),
                        Some(Err(e)) => {
                            self.error = Some((i, e));
                            break;
                        }
                        None => self.core.end(i),
                    }
                }
            }
        }
    }
}
