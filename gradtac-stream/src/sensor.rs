//! Sensor identities.

use serde::{Deserialize, Serialize};
use std::borrow::Borrow;
use std::fmt;
use std::sync::Arc;

/// The name of one sensor (a fingertip: `ff`, `th`, …), cheap to clone.
///
/// Streams of several sensors are *keyed* by it: [`Keyed`](crate::Keyed) keeps one stage
/// state per `SensorId`. Equality is by name.
#[derive(Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct SensorId(Arc<str>);

impl SensorId {
    /// A sensor id from its name.
    pub fn new(name: impl AsRef<str>) -> Self {
        SensorId(Arc::from(name.as_ref()))
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// True when both ids share one allocation (a fast path before comparing names).
    pub fn ptr_eq(&self, other: &SensorId) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl fmt::Debug for SensorId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", &*self.0)
    }
}

impl fmt::Display for SensorId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<&str> for SensorId {
    fn from(s: &str) -> Self {
        SensorId::new(s)
    }
}

impl Borrow<str> for SensorId {
    fn borrow(&self) -> &str {
        &self.0
    }
}

/// Anything that belongs to one sensor; [`Keyed`](crate::Keyed) routes by it.
pub trait HasSensor {
    /// The sensor this item belongs to.
    fn sensor(&self) -> &SensorId;
}
