//! Scene TOML + planner: any bytes as a scene file (relative paths resolve in an empty
//! scratch directory), planned and explained as `gradtac explain` does.
#![no_main]

use gradtac::{Plan, Scene};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let dir = gradtac_fuzz::scratch().join("scene");
    let Ok(scene) = Scene::from_toml(text, &dir, Path::new("fuzz-scene.toml")) else { return };
    if let Ok(plan) = Plan::new(&scene) {
        let _ = plan.explain(&scene);
    }
});
