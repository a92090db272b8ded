//! Plot reader: any bytes as a Parquet file given to `gradtac plot` (read, laid out and
//! drawn to a PNG in the scratch directory).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    gradtac_fuzz::contain_dependency_panics();
    let input = gradtac_fuzz::file("in.parquet", data);
    let png = gradtac_fuzz::scratch().join("out.png");
    let _ = gradtac::plot::plot_parquet(&input, &png);
});
