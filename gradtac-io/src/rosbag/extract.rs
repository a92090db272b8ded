//! From decoded messages to taxel frames: which field holds one fingertip's electrodes and
//! which its time, found in the message definition, and the per-sensor bookkeeping shared by
//! the ROS bag and MCAP sources.
//!
//! A topic fits when its message type has
//! - a field `tactiles`, an array of messages each with an integer array `electrodes`
//!   (`sr_robot_msgs/BiotacAll`: `Biotac[5] tactiles`, slots ff, mf, rf, lf, th) — the sensor's
//!   `finger` picks the slot; or
//! - an integer array `electrodes` of its own (one fingertip per message; no `finger`).
//!
//! Time is the message's `header.stamp` (ROS 1 `time`, or ROS 2 `builtin_interfaces/Time`
//! with `sec`/`nanosec`) by default, or the time the recorder received it
//! ([`StampSource::Record`]). Times must not decrease per sensor; a message whose electrode
//! count differs from the sensor's first message is an error.

use super::decode::{decode, Value, Wire};
use super::msgdef::{Arity, Dialect, FieldType, Primitive, Schema};
use super::{Finger, StampSource};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use std::collections::{HashMap, VecDeque};
use std::path::Path;
use std::sync::Arc;

/// Where the electrodes and the stamp are in a decoded message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ElectrodePlan {
    /// `tactiles` field and slot, when the message holds several fingertips.
    tactiles: Option<(usize, usize)>,
    /// The `electrodes` field (of the slot's type, or of the root).
    electrodes: usize,
    /// `header` and `stamp` fields, when time comes from the header.
    stamp: Option<(usize, usize)>,
}

fn is_int_array(ty: FieldType, arity: Arity) -> bool {
    matches!(ty, FieldType::Primitive(p) if p.is_integer() && p != Primitive::U64) && arity != Arity::One
}

impl ElectrodePlan {
    /// Find the fields in `schema` (see the [module docs](self)); the error says what is
    /// missing.
    pub fn new(schema: &Schema, finger: Option<Finger>, time: StampSource) -> Result<Self, String> {
        let root = schema.root_type();
        let (tactiles, electrodes) = match (root.field("tactiles"), root.field("electrodes")) {
            (Some(t), _) => {
                let f = &root.fields[t];
                let FieldType::Message(elem) = f.ty else {
                    return Err("its `tactiles` field is not an array of messages".into());
                };
                if f.arity == Arity::One {
                    return Err("its `tactiles` field is not an array".into());
                }
                let finger = finger.ok_or("it holds several fingertips (`tactiles`): name one with finger = \"ff\" | \"mf\" | \"rf\" | \"lf\" | \"th\"")?;
                if let Arity::Fixed(n) = f.arity {
                    if finger.slot() >= n as usize {
                        return Err(format!(
                            "finger {} is slot {}, but `tactiles` has {n} slots",
                            finger.as_str(),
                            finger.slot()
                        ));
                    }
                }
                let et = &schema.types[elem];
                let e = et
                    .field("electrodes")
                    .ok_or_else(|| format!("its tactile type {} has no `electrodes` field", et.name))?;
                if !is_int_array(et.fields[e].ty, et.fields[e].arity) {
                    return Err(format!("{}.electrodes is not an integer array", et.name));
                }
                (Some((t, finger.slot())), e)
            }
            (None, Some(e)) => {
                if !is_int_array(root.fields[e].ty, root.fields[e].arity) {
                    return Err("its `electrodes` field is not an integer array".into());
                }
                if let Some(f) = finger {
                    return Err(format!(
                        "it carries one fingertip (`electrodes`), so finger = {:?} selects nothing: leave it out",
                        f.as_str()
                    ));
                }
                (None, e)
            }
            (None, None) => {
                return Err("it has neither `tactiles` (fingertips with `electrodes`) nor an `electrodes` array".into())
            }
        };
        let stamp = match time {
            StampSource::Record => None,
            StampSource::Header => {
                let no = || {
                    "it has no `header.stamp`: use time = \"record\" for the time the recorder received each message"
                        .to_string()
                };
                let h = root.field("header").ok_or_else(no)?;
                let FieldType::Message(ht) = root.fields[h].ty else { return Err(no()) };
                let s = schema.types[ht].field("stamp").ok_or_else(no)?;
                let ok = match schema.types[ht].fields[s].ty {
                    FieldType::Primitive(Primitive::Time) => true,
                    FieldType::Message(tt) => {
                        let t = &schema.types[tt];
                        t.field("sec").is_some() && (t.field("nanosec").is_some() || t.field("nsec").is_some())
                    }
                    _ => false,
                };
                if !ok {
                    return Err("its header.stamp is not a time".into());
                }
                Some((h, s))
            }
        };
        Ok(ElectrodePlan { tactiles, electrodes, stamp })
    }

    /// The electrodes (as `f64`) and the header stamp (ns since the epoch) of a decoded message.
    pub fn extract(&self, v: &Value) -> Result<(Vec<f64>, Option<i64>), String> {
        let stamp = match self.stamp {
            None => None,
            Some((h, s)) => Some(stamp_nanos(field(field(v, h)?, s)?)?),
        };
        let holder = match self.tactiles {
            None => v,
            Some((t, slot)) => match field(v, t)? {
                Value::List(items) => items
                    .get(slot)
                    .ok_or_else(|| format!("`tactiles` has {} entries; this finger is slot {slot}", items.len()))?,
                _ => return Err("internal: tactiles did not decode as a list".into()),
            },
        };
        match field(holder, self.electrodes)? {
            Value::Ints(e) => Ok((e.iter().map(|&x| x as f64).collect(), stamp)),
            _ => Err("internal: electrodes did not decode as integers".into()),
        }
    }
}

fn field(v: &Value, i: usize) -> Result<&Value, String> {
    match v {
        Value::Struct(f) => f.get(i).ok_or_else(|| "internal: field index".to_string()),
        _ => Err("internal: not a message".into()),
    }
}

fn stamp_nanos(v: &Value) -> Result<i64, String> {
    let (sec, nsec) = match v {
        Value::Time { sec, nsec } => (*sec, *nsec),
        Value::Struct(f) => match f.as_slice() {
            [Value::Int(s), Value::Int(n), ..] => (*s, *n),
            _ => return Err("header.stamp is not sec + nanosec integers".into()),
        },
        _ => return Err("header.stamp is not a time".into()),
    };
    if !(0..1_000_000_000).contains(&nsec) {
        return Err(format!("header.stamp has {nsec} nanoseconds (must be 0 … 999999999)"));
    }
    // a schema may declare `int64 sec` (found by the `mcap` fuzz target): any i64 seconds
    sec.checked_mul(1_000_000_000)
        .and_then(|ns| ns.checked_add(nsec))
        .ok_or_else(|| format!("header.stamp of {sec} s does not fit in i64 nanoseconds (±292 years)"))
}

/// One scene sensor read from a recorded-hand file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BagSensor {
    /// The sensor's id (its frames' `sensor`).
    pub sensor: SensorId,
    /// The topic it reads.
    pub topic: String,
    /// The fingertip slot, for messages holding several.
    pub finger: Option<Finger>,
    /// Where its time comes from.
    pub time: StampSource,
}

struct SensorState {
    spec: BagSensor,
    seq: u64,
    last: Option<i64>,
    taxels: Option<usize>,
}

/// What went wrong with one message or connection, for the caller to place in the file.
pub(crate) struct Fault {
    pub topic: String,
    pub msg_type: String,
    pub index: Option<u64>,
    pub reason: String,
}

/// Routes the messages of a file's connections to the sensors that read their topics.
pub(crate) struct Demux {
    sensors: Vec<SensorState>,
    /// Per connection (or MCAP channel): its topic, type, schema and the (sensor, plan) pairs.
    routes: HashMap<u32, Route>,
    wire: Wire,
    dialect: Dialect,
}

struct Route {
    topic: String,
    msg_type: String,
    schema: Option<Arc<Schema>>,
    plans: Vec<(usize, ElectrodePlan)>,
}

impl Demux {
    pub fn new(sensors: Vec<BagSensor>, wire: Wire, dialect: Dialect) -> Self {
        let sensors = sensors.into_iter().map(|spec| SensorState { spec, seq: 0, last: None, taxels: None }).collect();
        Demux { sensors, routes: HashMap::new(), wire, dialect }
    }

    /// True when some sensor reads `topic`.
    pub fn reads(&self, topic: &str) -> bool {
        self.sensors.iter().any(|s| s.spec.topic == topic)
    }

    /// True once `id` has been registered.
    pub fn knows(&self, id: u32) -> bool {
        self.routes.contains_key(&id)
    }

    /// Register a connection / channel; an error when a sensor reads its topic and the type
    /// does not fit.
    pub fn connect(&mut self, id: u32, topic: &str, msg_type: &str, definition: &str) -> Result<(), Fault> {
        let readers: Vec<usize> =
            self.sensors.iter().enumerate().filter(|(_, s)| s.spec.topic == topic).map(|(i, _)| i).collect();
        let fault = |reason: String| Fault { topic: topic.into(), msg_type: msg_type.into(), index: None, reason };
        let mut route = Route { topic: topic.into(), msg_type: msg_type.into(), schema: None, plans: Vec::new() };
        if !readers.is_empty() {
            let schema = Schema::parse(msg_type, definition, self.dialect).map_err(|e| fault(e.to_string()))?;
            for i in readers {
                let s = &self.sensors[i].spec;
                let plan = ElectrodePlan::new(&schema, s.finger, s.time)
                    .map_err(|r| fault(format!("sensor {:?} cannot read this type: {r}", s.sensor.as_str())))?;
                route.plans.push((i, plan));
            }
            route.schema = Some(Arc::new(schema));
        }
        self.routes.insert(id, route);
        Ok(())
    }

    /// Decode one message of connection `id` into frames for the sensors reading it.
    pub fn message(
        &mut self,
        id: u32,
        index: u64,
        record_ns: i64,
        bytes: &[u8],
        out: &mut Vec<TaxelFrame>,
    ) -> Result<(), Fault> {
        let Some(route) = self.routes.get(&id) else { return Ok(()) };
        let Some(schema) = &route.schema else { return Ok(()) };
        let fault = |reason: String| Fault {
            topic: route.topic.clone(),
            msg_type: route.msg_type.clone(),
            index: Some(index),
            reason,
        };
        let value = decode(schema, self.wire, bytes).map_err(|e| fault(e.to_string()))?;
        for (i, plan) in &route.plans {
            let st = &mut self.sensors[*i];
            let (values, stamp) = plan.extract(&value).map_err(fault)?;
            let t = stamp.unwrap_or(record_ns);
            if let Some(prev) = st.last.filter(|&p| t < p) {
                return Err(fault(format!(
                    "sensor {:?}: time goes back ({t} ns is {} ns before the previous message's)",
                    st.spec.sensor.as_str(),
                    prev - t
                )));
            }
            match st.taxels {
                None if values.is_empty() => {
                    return Err(fault(format!(
                        "sensor {:?}: the message has no electrodes (an empty fingertip slot?)",
                        st.spec.sensor.as_str()
                    )))
                }
                None => st.taxels = Some(values.len()),
                Some(n) if n != values.len() => {
                    return Err(fault(format!(
                        "sensor {:?}: {} electrodes, but earlier messages had {n}",
                        st.spec.sensor.as_str(),
                        values.len()
                    )))
                }
                _ => {}
            }
            st.last = Some(t);
            out.push(TaxelFrame::new(st.spec.sensor.clone(), Timestamp(t), st.seq, values));
            st.seq += 1;
        }
        Ok(())
    }

    /// At the end of the file: an error for the first sensor whose topic never appeared,
    /// listing the topics that did.
    pub fn check_topics(&self) -> Result<(), String> {
        for s in &self.sensors {
            if !self.routes.values().any(|r| r.topic == s.spec.topic) {
                let mut topics: Vec<String> =
                    self.routes.values().map(|r| format!("{} ({})", r.topic, r.msg_type)).collect();
                topics.sort();
                topics.dedup();
                return Err(format!(
                    "sensor {:?}: topic {} is not in the file; its topics: {}",
                    s.spec.sensor.as_str(),
                    s.spec.topic,
                    if topics.is_empty() { "none".into() } else { topics.join(", ") }
                ));
            }
        }
        Ok(())
    }
}

/// The `Iterator::next` shared by the ROS bag and MCAP readers: both decode messages into a
/// queue of frames through a [`Demux`], and at the end of the file report a requested topic
/// that never appeared. The first error ends the iteration.
pub(crate) trait QueuedFrames {
    /// Decode messages until a frame is queued (`Ok(true)`) or the file ends (`Ok(false)`).
    fn decode_more(&mut self) -> crate::Result<bool>;
    /// The queue of decoded frames and whether the reader has ended.
    fn queue(&mut self) -> (&mut VecDeque<TaxelFrame>, &mut bool);
    /// The demultiplexer (for the end-of-file topic check).
    fn demux(&self) -> &Demux;
    /// The file (for errors).
    fn path(&self) -> &Path;

    /// The next frame, or the error that ends the iteration.
    fn next_frame(&mut self) -> Option<crate::Result<TaxelFrame>> {
        loop {
            let (pending, done) = self.queue();
            if let Some(f) = pending.pop_front() {
                return Some(Ok(f));
            }
            if *done {
                return None;
            }
            let r = self.decode_more();
            if !matches!(r, Ok(true)) {
                *self.queue().1 = true;
            }
            match r {
                Ok(true) => {}
                Ok(false) => {
                    if let Err(reason) = self.demux().check_topics() {
                        let path = self.path().to_path_buf();
                        return Some(Err(crate::Error::Bag { path, site: Box::default(), reason }));
                    }
                }
                Err(e) => return Some(Err(e)),
            }
        }
    }
}
