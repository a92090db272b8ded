use gradtac::stages::centroid::Centroid;
use gradtac::stages::locate::LocateConfig;
use gradtac::stream::{Layout, Stage, TaxelFrame, Timestamp};
fn main() {
    let p = std::env::args().nth(1).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let l = Layout::biotac_sp();
    let mut c = Centroid::try_new(&LocateConfig::default(), &l).unwrap();
    let mut prev: Option<[f64; 2]> = None;
    for (k, line) in text.lines().skip(1).enumerate() {
        let v: Vec<f64> = line.split(',').map(|x| x.trim().parse().unwrap()).collect();
        let mut out = Vec::new();
        c.push(TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, v), &mut out).unwrap();
        let rel = c.detector().relative();
        let act = rel.iter().filter(|&&r| r > 0.0).count();
        let tot: f64 = rel.iter().map(|r| r * r).sum();
        let top: Vec<String> = {
            let mut ix: Vec<usize> = (0..24).collect();
            ix.sort_by(|&a, &b| rel[b].total_cmp(&rel[a]));
            ix[..3].iter().map(|&i| format!("e{}:{:.4}", i + 1, rel[i])).collect()
        };
        match out[0].outcome.contact() {
            Some(m) => {
                let j = prev.map_or(0.0, |p| (p[0] - m.centroid_mm[0]).hypot(p[1] - m.centroid_mm[1]));
                if j > 1.0 || k % 25 == 0 {
                    println!(
                        "{k} ({:.2},{:.2}) jump {j:.2} act {act} tot {tot:.2e} {}",
                        m.centroid_mm[0],
                        m.centroid_mm[1],
                        top.join(" ")
                    );
                }
                prev = Some(m.centroid_mm);
            }
            None => {
                if k % 25 == 0 {
                    println!("{k} none");
                }
                prev = None;
            }
        }
    }
    println!("sigma {:?}", c.detector().noise().iter().map(|s| (s * 100.0).round() / 100.0).collect::<Vec<_>>());
}
