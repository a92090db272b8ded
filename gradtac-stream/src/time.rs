//! Timestamps: integer nanoseconds.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::{Add, Sub};

/// Smallest fixed sample rate a source accepts (Hz): one frame per ~17 minutes. At this rate
/// 9.2 million frames fit in `i64` nanoseconds; [`Timestamp::checked_at_rate`] catches the frame
/// where time would overflow.
pub const MIN_RATE_HZ: f64 = 1e-3;
/// Largest fixed sample rate a source accepts (Hz): frames 1 ns apart.
pub const MAX_RATE_HZ: f64 = 1e9;

/// A point in time, in integer **nanoseconds**.
///
/// # Epoch rule
/// A timestamp is nanoseconds since an epoch that belongs to the *source*:
/// - live sources (a CAN bus) stamp frames with nanoseconds since the Unix epoch (UTC);
/// - file sources with a time column use that column's own origin, converted to ns
///   (a column in seconds is multiplied by 10⁹ and rounded to the nearest ns);
/// - file sources without a time column (a fixed sample rate) start at **0 at the first
///   frame** and advance by `round(k · 10⁹ / rate_hz)` ns for frame `k`, so that rounding
///   error never accumulates.
///
/// Timestamps of different sensors are comparable (and [`merge`](crate::merge) orders by
/// them) only when their sources share an epoch; a scene that mixes live and recorded
/// sources is the user's responsibility.
///
/// `i64` nanoseconds span ±292 years around the epoch.
#[derive(Copy, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Timestamp(pub i64);

impl Timestamp {
    /// The epoch itself.
    pub const ZERO: Timestamp = Timestamp(0);

    /// From integer nanoseconds.
    pub const fn from_nanos(ns: i64) -> Self {
        Timestamp(ns)
    }

    /// From seconds, rounded to the nearest nanosecond. Returns `None` for non-finite input
    /// or a value outside the `i64` nanosecond range.
    pub fn from_secs_f64(s: f64) -> Option<Self> {
        let ns = (s * 1e9).round();
        if ns.is_finite() && ns >= i64::MIN as f64 && ns < i64::MAX as f64 {
            Some(Timestamp(ns as i64))
        } else {
            None
        }
    }

    /// The time of frame `k` at a fixed sample rate, starting at 0: `round(k·10⁹/rate_hz)`.
    pub fn at_rate(k: u64, rate_hz: f64) -> Self {
        Timestamp(((k as f64) * 1e9 / rate_hz).round() as i64)
    }

    /// [`at_rate`](Self::at_rate), or `None` when frame `k`'s time does not fit in `i64`
    /// nanoseconds (≈ 292 years): sources stop with an error at that frame instead of
    /// writing a saturated time.
    pub fn checked_at_rate(k: u64, rate_hz: f64) -> Option<Self> {
        let ns = ((k as f64) * 1e9 / rate_hz).round();
        (ns.is_finite() && ns >= 0.0 && ns < i64::MAX as f64).then_some(Timestamp(ns as i64))
    }

    /// Check a fixed sample rate: finite and within [`MIN_RATE_HZ`, `MAX_RATE_HZ`]. The
    /// message says what is wrong and how many frames the rate can time.
    pub fn check_rate_hz(rate_hz: f64) -> Result<(), String> {
        if rate_hz.is_finite() && (MIN_RATE_HZ..=MAX_RATE_HZ).contains(&rate_hz) {
            Ok(())
        } else {
            Err(format!(
                "rate_hz must be finite and within [{MIN_RATE_HZ:e}, {MAX_RATE_HZ:e}] Hz (below, frame times leave \
                 the i64-nanosecond range within {} frames; above, frames are less than 1 ns apart), got {}",
                (i64::MAX as f64 * MIN_RATE_HZ * 1e-9) as u64,
                crate::num::Short(rate_hz)
            ))
        }
    }

    /// Integer nanoseconds.
    pub const fn as_nanos(self) -> i64 {
        self.0
    }

    /// Seconds as `f64` (exact below 2⁵³ ns ≈ 104 days).
    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 * 1e-9
    }
}

impl fmt::Debug for Timestamp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}ns", self.0)
    }
}

impl fmt::Display for Timestamp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.9}s", self.as_secs_f64())
    }
}

/// `ns` nanoseconds later, **saturating** at the ends of the `i64` range (a time from a file
/// near `i64::MAX` plus a window never wraps to the far past, nor panics in a debug build);
/// [`checked_add`](Timestamp::checked_add) says when it would not fit.
impl Add<i64> for Timestamp {
    type Output = Timestamp;
    fn add(self, ns: i64) -> Timestamp {
        Timestamp(self.0.saturating_add(ns))
    }
}

/// `ns` nanoseconds earlier, saturating like `+`.
impl Sub<i64> for Timestamp {
    type Output = Timestamp;
    /// `ns` nanoseconds earlier.
    fn sub(self, ns: i64) -> Timestamp {
        Timestamp(self.0.saturating_sub(ns))
    }
}

impl Timestamp {
    /// `ns` nanoseconds later, or `None` outside the `i64` range.
    pub fn checked_add(self, ns: i64) -> Option<Timestamp> {
        self.0.checked_add(ns).map(Timestamp)
    }

    /// `ns` nanoseconds earlier, or `None` outside the `i64` range.
    pub fn checked_sub(self, ns: i64) -> Option<Timestamp> {
        self.0.checked_sub(ns).map(Timestamp)
    }

    /// The difference `self − earlier` in nanoseconds, or `None` when it does not fit in `i64`
    /// (times at both ends of the range).
    pub fn checked_since(self, earlier: Timestamp) -> Option<i64> {
        self.0.checked_sub(earlier.0)
    }
}

impl Timestamp {
    /// This time moved later by a [`Duration`](std::time::Duration) (saturating at the `i64` range).
    pub fn after(self, d: std::time::Duration) -> Timestamp {
        Timestamp(self.0.saturating_add(i64::try_from(d.as_nanos()).unwrap_or(i64::MAX)))
    }

    /// The non-negative [`Duration`](std::time::Duration) from `earlier` to this time (zero
    /// when `earlier` is later).
    pub fn since(self, earlier: Timestamp) -> std::time::Duration {
        std::time::Duration::from_nanos(self.0.saturating_sub(earlier.0).max(0) as u64)
    }
}

/// The difference in nanoseconds, saturating at the `i64` range (times ±292 years apart);
/// [`checked_since`](Timestamp::checked_since) says when it would not fit.
impl Sub for Timestamp {
    type Output = i64;
    /// The difference in nanoseconds.
    fn sub(self, rhs: Timestamp) -> i64 {
        self.0.saturating_sub(rhs.0)
    }
}

/// Anything that carries a timestamp; [`merge`](crate::merge) orders by it.
pub trait Timed {
    /// The item's time.
    fn time(&self) -> Timestamp;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_does_not_accumulate_rounding() {
        // 3 Hz: 1e9/3 is not an integer; frame 3 must land on exactly 1 s.
        assert_eq!(Timestamp::at_rate(3, 3.0), Timestamp(1_000_000_000));
        assert_eq!(Timestamp::at_rate(1, 3.0), Timestamp(333_333_333));
        assert_eq!(Timestamp::at_rate(2, 3.0), Timestamp(666_666_667));
    }

    #[test]
    fn tiny_rates_are_refused_and_overflow_is_caught_at_its_frame() {
        assert!(Timestamp::check_rate_hz(1e-9).unwrap_err().contains("rate_hz"));
        assert!(Timestamp::check_rate_hz(f64::NAN).is_err() && Timestamp::check_rate_hz(1e12).is_err());
        assert!(Timestamp::check_rate_hz(100.0).is_ok() && Timestamp::check_rate_hz(MIN_RATE_HZ).is_ok());
        assert_eq!(Timestamp::checked_at_rate(3, 3.0), Some(Timestamp(1_000_000_000)));
        // at 1e-9 Hz frame 9 is 9e18 ns (fits), frame 10 is 1e19 ns (does not)
        assert!(Timestamp::checked_at_rate(9, 1e-9).is_some());
        assert_eq!(Timestamp::checked_at_rate(10, 1e-9), None);
        assert!(Timestamp::checked_at_rate(9_223_372, MIN_RATE_HZ).is_some());
        assert!(Timestamp::checked_at_rate(9_223_373, MIN_RATE_HZ).is_none());
    }

    #[test]
    fn seconds_round_trip_and_reject_nonfinite() {
        assert_eq!(Timestamp::from_secs_f64(1.5), Some(Timestamp(1_500_000_000)));
        assert_eq!(Timestamp::from_secs_f64(f64::NAN), None);
        assert_eq!(Timestamp::from_secs_f64(1e300), None);
        assert_eq!(Timestamp(2_000_000_000) - Timestamp(500), 1_999_999_500);
        assert_eq!(Timestamp(2_000) - 500, Timestamp(1_500));
        // at the ends of the range: saturating, never wrapping (nor a debug-build panic)
        assert_eq!(Timestamp(i64::MAX) + 1, Timestamp(i64::MAX));
        assert_eq!(Timestamp(i64::MIN) - 1, Timestamp(i64::MIN));
        assert_eq!(Timestamp(i64::MAX) - Timestamp(i64::MIN), i64::MAX);
        assert_eq!(Timestamp(i64::MIN) - Timestamp(i64::MAX), i64::MIN);
        assert_eq!(Timestamp(i64::MAX).checked_add(1), None);
        assert_eq!(Timestamp(i64::MIN).checked_sub(1), None);
        assert_eq!(Timestamp(i64::MAX).checked_since(Timestamp(-1)), None);
        assert_eq!(Timestamp(5).checked_since(Timestamp(2)), Some(3));
        let d = std::time::Duration::from_millis(10);
        assert_eq!(Timestamp(5).after(d), Timestamp(10_000_005));
        assert_eq!(Timestamp(10_000_005).since(Timestamp(5)), d);
        assert_eq!(Timestamp(5).since(Timestamp(10)), std::time::Duration::ZERO);
    }
}
