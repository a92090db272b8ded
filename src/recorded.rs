//! Opening recorded-hand files (ROS bags, MCAP) for a run: one pass per file, shared by
//! every sensor of the scene that reads it.

use crate::plan::Plan;
use crate::scene::{Scene, SourceSpec};
use crate::Error;
use futures::StreamExt;
use gradtac_io::rosbag::{BagSensor, RosbagFrames};
use gradtac_stream::{SensorId, TaxelFrame};
use std::path::Path;
use std::pin::Pin;

type FrameStream = Pin<Box<dyn futures::Stream<Item = Result<TaxelFrame, gradtac_stream::Error>> + Send>>;

/// The sensors the plan runs whose source is the file `path` (resolved) of kind `kind`.
fn sensors_of(scene: &Scene, plan: &Plan, path: &Path, kind: &str) -> Vec<BagSensor> {
    plan.sensors
        .iter()
        .filter(|p| p.is_read())
        .filter_map(|p| match &scene.sensors[p.index].source {
            SourceSpec::Rosbag(c) if kind == "rosbag" && scene.resolve(&c.path) == path => {
                Some(c.sensor(SensorId::new(&p.name)))
            }
            _ => None,
        })
        .collect()
}

/// Open the ROS bag at `path` (resolved) for every sensor of the plan that reads it.
pub(crate) fn open_rosbag(scene: &Scene, plan: &Plan, path: &Path) -> Result<FrameStream, Error> {
    let frames = RosbagFrames::open(path, sensors_of(scene, plan, path, "rosbag"))?;
    let it = frames.map(|r| r.map_err(gradtac_stream::Error::from));
    Ok(Box::pin(gradtac_io::blocking_stream(it, 1024).map(|r| r)))
}
