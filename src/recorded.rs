//! Opening recorded-hand files (ROS bags, MCAP) for a run: one pass per file, shared by
//! every sensor of the scene that reads it.

use crate::plan::Plan;
use crate::scene::{Scene, SourceSpec};
use crate::Error;
use gradtac_io::rosbag::{BagSensor, McapFrames, RosbagFrames};
use gradtac_stream::{SensorId, TaxelFrame};
use std::path::Path;
use std::pin::Pin;

type FrameStream = Pin<Box<dyn futures::Stream<Item = Result<TaxelFrame, gradtac_stream::Error>> + Send>>;

/// Open the recorded-hand file at `path` (resolved) for every sensor of the plan that reads
/// it (a ROS bag or an MCAP file, by the sensors' source kind).
pub(crate) fn open(scene: &Scene, plan: &Plan, path: &Path) -> Result<FrameStream, Error> {
    let mut sensors: Vec<BagSensor> = Vec::new();
    let mut mcap = false;
    for p in plan.sensors.iter().filter(|p| p.is_read()) {
        match &scene.sensors[p.index].source {
            SourceSpec::Rosbag(c) if scene.resolve(&c.path) == path => sensors.push(c.sensor(SensorId::new(&p.name))),
            SourceSpec::Mcap(c) if scene.resolve(&c.path) == path => {
                mcap = true;
                sensors.push(c.sensor(SensorId::new(&p.name)));
            }
            _ => {}
        }
    }
    let err = |e: gradtac_io::Error| gradtac_stream::Error::from(e);
    if mcap {
        let it = McapFrames::open(path, sensors)?.map(move |r| r.map_err(err));
        Ok(Box::pin(gradtac_io::blocking_stream_chunked(it, 1024, 256)))
    } else {
        let it = RosbagFrames::open(path, sensors)?.map(move |r| r.map_err(err));
        Ok(Box::pin(gradtac_io::blocking_stream_chunked(it, 1024, 256)))
    }
}
