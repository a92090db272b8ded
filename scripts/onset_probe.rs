//! Offline analysis of the slip onset fit on the TUNING members (never the held-out ones):
//! the evidence behind `gradtac_stages::slip`'s "What the tuning members show" notes.
//!
//! ```text
//! cargo run --release --example slip_eval -- onsetdump > /tmp/tuning.txt
//! rustc -O -o /tmp/onset_probe scripts/onset_probe.rs
//! /tmp/onset_probe /tmp/tuning.txt oracle   # the fit with each grasp's true start (an oracle)
//! /tmp/onset_probe /tmp/tuning.txt conf     # which start the fit chooses, per true shape
//! /tmp/onset_probe /tmp/tuning.txt an       # the oracle's per-finger error by speed, lag, grip, load
//! /tmp/onset_probe /tmp/tuning.txt var|var2|grid|win|single   # estimator variants
//! /tmp/onset_probe /tmp/tuning.txt pen     # the stage's fit (ramp null, linear_cubic, weighted) with a
//!                                          # penalty per start length (JOINT=1: one start for both fingers)
//! /tmp/onset_probe /tmp/tuning.txt stack   # a linear stack of the starts' change points, 5-fold CV over seeds
//! /tmp/onset_probe /tmp/tuning.txt joint   # (stop 32) both fingers in one likelihood, posterior means,
//!                                          # split test, lead per fitted start, two-finger oracles;
//!                                          # START_SET=smooth|fine|lc05|lc05n for other start sets.
//!                                          # Dump for it: DUMP_POSITION=fit DUMP_SEEDS=400 ... -- onsetdump
//!                                          # (the stage's own onset positions, seeds 0..400 < held out)
//! (round 3: `DUMP_POSITION=linear` or `DUMP_FIT=1` on the dump for the other onset positions;
//! drop history lines with fewer than 8 points first: `awk '$1=="G" || NF>=40'`)
//! ```
//! Each row: per start shape median |error| / mean signed (ms) after the row's own lead (its
//! mean signed error over all shapes), and the worst shape. A reimplementation of the stage's
//! fit (direct sums; the stage's first row reproduces it) — standalone, no dependencies.
#![allow(dead_code, unused)]
use std::io::BufRead;
#[derive(Clone)]
struct G { seed: u64, right: bool, shape: String, r: f64, grip: f64, load: f64, lag: f64, v: f64, onset: f64, fon: [f64;2], dec: f64, est0: f64, plag: [f64;2], h: Vec<(usize, f64, Vec<(f64,f64)>)> }
fn load(p:&str)->Vec<G>{
  let f=std::fs::File::open(p).unwrap(); let mut out:Vec<G>=vec![];
  for l in std::io::BufReader::new(f).lines(){ let l=l.unwrap(); let w:Vec<&str>=l.split(' ').collect();
    if w[0]=="G"{ let x=|i:usize| w[i].parse::<f64>().unwrap();
      out.push(G{seed:w[1].parse().unwrap(),right:w[3]=="1",shape:w[4].into(),r:x(5),grip:x(6),load:x(7),lag:x(8),v:x(9),onset:x(10),fon:[x(11),x(12)],dec:x(13),est0:x(14),plag:[x(15),x(16)],h:vec![]});
    } else { let k:usize=w[1].parse().unwrap(); let m:f64=w[2].parse().unwrap();
      let pts=w[3..].iter().map(|s|{let mut a=s.split(':'); (a.next().unwrap().parse().unwrap(),a.next().unwrap().parse().unwrap())}).collect();
      out.last_mut().unwrap().h.push((k,m,pts)); } }
  out }
// start progress z(t-c) for linear(r)/smooth(r)/power
#[derive(Clone,Copy,Debug)] enum S{L(f64),Sm(f64),P(f64,f64)}
fn z(s:S,t:f64,c:f64)->f64{ let d=t-c; if d<=0.0{return 0.0}
  match s { S::L(r)=> if d<r {d*d/(2.0*r)} else {d-r/2.0},
    S::Sm(r)=> if d<r {d*d*d/(r*r)-d*d*d*d/(2.0*r*r*r)} else {d-r/2.0},
    S::P(p,r)=> if d<r { r/p*(d/r).powf(p) } else { d - r + r/p } } }
fn sse(h:&[(f64,f64)],c:f64,s:S)->Option<(f64,f64)>{ let m=h.len() as f64;
  let (mut sz,mut su)=(0.0,0.0); for p in h{sz+=z(s,p.0,c);su+=p.1}
  let (mz,mu)=(sz/m,su/m); let (mut szz,mut szu)=(0.0,0.0);
  for p in h{let zz=z(s,p.0,c)-mz; szz+=zz*zz; szu+=zz*(p.1-mu);} if szz<=0.0{return None}
  let b=szu/szz; let e=h.iter().map(|p|(p.1-mu-b*(z(s,p.0,c)-mz)).powi(2)).sum(); Some((e,b)) }
fn fit(h:&[(f64,f64)],starts:&[S])->Option<(f64,S,f64)>{ let n=h.len(); if n<8{return None}
  let mut best:Option<(f64,f64,S)>=None;
  for k in 3..n-3 { for &s in starts { if let Some((e,_))=sse(h,h[k].0,s){ if best.map_or(true,|b|e<b.0){best=Some((e,h[k].0,s))}}}}
  best.map(|b|(b.1,b.2,b.0)) }
fn med(v:&mut Vec<f64>)->f64{ v.sort_by(f64::total_cmp); if v.is_empty(){return f64::NAN} v[(v.len()-1)/2] }
fn mean(v:&[f64])->f64{v.iter().sum::<f64>()/v.len() as f64}
fn report(name:&str, gs:&[G], est:&dyn Fn(&G)->Option<f64>){
  let mut all=vec![]; let mut per:Vec<(String,Vec<f64>)>=vec![];
  for g in gs.iter().filter(|g|g.right){ if let Some(e)=est(g){ let err=e-g.onset; all.push(err);
     match per.iter_mut().find(|p|p.0==g.shape){Some(p)=>p.1.push(err),None=>per.push((g.shape.clone(),vec![err]))} } }
  let lead=mean(&all);
  let mut line=format!("{name:40} n {} lead {:+.0} |", all.len(), lead*1e3); let mut worst:f64=0.0; let mut worstm:f64=0.0;
  for sh in ["step","linear","smooth","exponential"]{ if let Some(p)=per.iter().find(|p|p.0==sh){ let e:Vec<f64>=p.1.iter().map(|x|x-lead).collect();
    let mut a:Vec<f64>=e.iter().map(|x|x.abs()).collect(); let m=med(&mut a); let mn=mean(&e); worst=worst.max(m); worstm=worstm.max(mn.abs());
    line+=&format!(" {sh} {:.0}/{:+.0}",m*1e3,mn*1e3);} }
  let mut a:Vec<f64>=all.iter().map(|x|(x-lead).abs()).collect();
  println!("{line} | all med {:.0} | worst {:.0}/{:.0}", med(&mut a)*1e3, worst*1e3, worstm*1e3);
}
fn main(){
  let path=std::env::args().nth(1).unwrap(); let gs=load(&path);
  let starts7=[S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4)];
  report("stage default (as dumped, no lead)", &gs, &|g| Some(g.est0));
  let cur=|g:&G, st:&[S]| { let ts:Vec<f64>=g.h.iter().filter(|h|h.1.abs()>=0.5).filter_map(|h|fit(&h.2,st).map(|f|f.0)).collect(); if ts.is_empty(){None}else{Some(mean(&ts))} };
  report("reimpl hinge 7 starts mean", &gs, &|g| cur(g,&starts7));
  let mode=std::env::args().nth(2).unwrap_or_default();
  if mode=="an" { analyse(&gs); }
  if mode=="var" { variants(&gs); }
  if mode=="grid" { grid(&gs); }
  if mode=="single" { singles(&gs); }
  if mode=="win" { windows(&gs); }
  if mode=="conf" { confusion(&gs); }
  if mode=="var2" { variants2(&gs); }
  if mode=="pen" { penalty(&gs); }
  if mode=="stack" { stack(&gs); }
  if mode=="joint" { joint(&gs); }
  if mode=="show" { for s in std::env::args().skip(3) { show(&gs, s.parse().unwrap()); } }
  if mode=="oracle" {
    report("oracle true shape", &gs, &|g| { let s = match g.shape.as_str(){"step"=>S::L(0.0),"linear"=>S::L(g.r),"smooth"=>S::Sm(g.r),_=>S::L(g.r)}; cur(g,&[s]) });
    report("step only", &gs, &|g| cur(g,&[S::L(0.0)]));
    // per finger error vs its own true onset
    for sh in ["step","linear","smooth"]{ let mut v=vec![]; for g in gs.iter().filter(|g|g.right&&g.shape==sh){ for h in &g.h { if h.1.abs()>=0.5 { if let Some(f)=fit(&h.2,&starts7){ v.push(f.0-g.fon[h.0]); } } } } println!("{sh} per-finger vs own onset: mean {:+.0} n {}", mean(&v)*1e3, v.len()); }
  }
}
fn analyse(gs:&[G]){
  // oracle per-finger error vs own onset, bucketed
  let mut rows=vec![];
  for g in gs.iter().filter(|g|g.right){ let s = match g.shape.as_str(){"step"=>S::L(0.0),"linear"=>S::L(g.r),"smooth"=>S::Sm(g.r),_=>S::L(g.r)};
    for h in &g.h { if h.1.abs()>=0.5 { if let Some(f)=fit(&h.2,&[s]){ rows.push((g.clone(),h.0,f.0-g.fon[h.0], f.2)); } } } }
  let b=|name:&str, key:&dyn Fn(&G,usize)->f64, edges:&[f64]| { let mut line=format!("{name}:"); for w in edges.windows(2){ let v:Vec<f64>=rows.iter().filter(|r|{let k=key(&r.0,r.1); k>=w[0]&&k<w[1]}).map(|r|r.2).collect(); let mut a:Vec<f64>=v.iter().map(|x|(x-mean(&v)).abs()).collect(); line+=&format!(" [{},{}) n{} mean {:+.0} mad {:.0};",w[0],w[1],v.len(),mean(&v)*1e3,med(&mut a)*1e3);} println!("{line}"); };
  b("speed", &|g,_|g.v, &[0.0,4.0,8.0,15.0,31.0]);
  b("plag", &|g,k|g.plag[k], &[0.0,0.02,0.04,0.06,0.1,1.0]);
  b("grip", &|g,_|g.grip, &[0.0,0.99,1.01,2.0]);
  b("load", &|g,_|g.load, &[0.0,0.01,4.0]);
  b("moved", &|g,k|g.h.iter().find(|h|h.0==k).unwrap().1.abs(), &[0.0,0.75,0.99,1.1]);
  b("dec-onset", &|g,_|g.dec-g.onset, &[0.0,0.3,0.5,0.8,5.0]);
}
fn variants(gs:&[G]){
  let starts7=[S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4)];
  // per grasp, per moving finger, per start: (c, sse, b, n)
  let fits:Vec<Vec<(usize,usize,Vec<(f64,f64,f64)>)>> = gs.iter().map(|g| g.h.iter().filter(|h|h.1.abs()>=0.5).map(|h| {
     let v=starts7.iter().map(|&s| { let f=fit(&h.2,&[s]).unwrap(); let b=sse(&h.2,f.0,s).unwrap().1; (f.0,f.2,b) }).collect(); (h.0,h.2.len(),v) }).collect()).collect();
  let idx:std::collections::HashMap<u64,usize>=gs.iter().enumerate().map(|(i,g)|(g.seed*10+g.h.len() as u64*0 + match g.fon[0].to_bits()%1 {_=>0},i)).collect();
  let _=idx;
  let find=|g:&G| gs.iter().position(|x| std::ptr::eq(x,g)).unwrap();
  for delta in [0.0, 0.05, 0.1, 0.15, 0.2, 0.3] {
    report(&format!("per-finger best, speed corr {delta} mm"), gs, &|g| { let f=&fits[find(g)]; if f.is_empty(){return None}
       let ts:Vec<f64>=f.iter().map(|(_,_,v)|{ let b=v.iter().min_by(|a,b|a.1.total_cmp(&b.1)).unwrap(); b.0 - delta/b.2.abs().max(0.5) }).collect(); Some(mean(&ts)) });
    report(&format!("joint shape, speed corr {delta} mm"), gs, &|g| { let f=&fits[find(g)]; if f.is_empty(){return None}
       let k=(0..7).min_by(|&a,&b| { let la:f64=f.iter().map(|(_,n,v)|*n as f64*v[a].1.ln()).sum(); let lb:f64=f.iter().map(|(_,n,v)|*n as f64*v[b].1.ln()).sum(); la.total_cmp(&lb)}).unwrap();
       let ts:Vec<f64>=f.iter().map(|(_,_,v)| v[k].0 - delta/v[k].2.abs().max(0.5)).collect(); Some(mean(&ts)) });
  }
}
fn show(gs:&[G], seed:u64){
  for g in gs.iter().filter(|g|g.seed==seed){ println!("seed {} {} r {:.2} v {:.1} onset {:.3} fon {:?} dec {:.3} est0 {:.3} plag {:?} grip {:.2} load {:.1}", g.seed,g.shape,g.r,g.v,g.onset,g.fon,g.dec,g.est0,g.plag,g.grip,g.load);
   for h in &g.h { let base:f64 = { let v:Vec<f64>=h.2.iter().filter(|p|p.0<g.fon[h.0]-0.05).map(|p|p.1).collect(); mean(&v)};
     let mut line=format!(" f{} moved {:.2}:", h.0,h.1); for p in h.2.iter().filter(|p| p.0>g.fon[h.0]-0.25) { line+=&format!(" {:+.0}:{:+.2}", (p.0-g.fon[h.0])*1e3, p.1-base); } println!("{line}"); } }
}
fn snr(h:&[(f64,f64)], c:f64, s:S)->f64 { let (e,b)=sse(h,c,s).unwrap(); let m=h.len() as f64; let mz=h.iter().map(|p|z(s,p.0,c)).sum::<f64>()/m; let szz:f64=h.iter().map(|p|(z(s,p.0,c)-mz).powi(2)).sum(); b*b*szz/e.max(1e-12) }
fn variants2(gs:&[G]){
  let sets:Vec<(&str,Vec<S>)>=vec![
    ("7",vec![S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4)]),
    ("lin4",vec![S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3)]),
    ("wide",vec![S::L(0.0),S::L(0.05),S::L(0.1),S::L(0.2),S::L(0.3),S::L(0.4),S::Sm(0.1),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4),S::Sm(0.5)]),
    ("pow",vec![S::L(0.0),S::P(2.0,0.1),S::P(2.0,0.2),S::P(2.0,0.3),S::P(3.0,0.2),S::P(3.0,0.3),S::P(3.0,0.4)]),
  ];
  for (name,st) in &sets {
    let per:Vec<Vec<(usize,f64,S,f64)>> = gs.iter().map(|g| g.h.iter().filter(|h|h.1.abs()>=0.5).filter_map(|h| fit(&h.2,st).map(|f|(h.0,f.0,f.1,snr(&h.2,f.0,f.1)))).collect()).collect();
    let find=|g:&G| gs.iter().position(|x| std::ptr::eq(x,g)).unwrap();
    report(&format!("{name} mean"), gs, &|g| { let f=&per[find(g)]; if f.is_empty(){None} else {Some(mean(&f.iter().map(|x|x.1).collect::<Vec<_>>()))} });
    report(&format!("{name} snr-weighted"), gs, &|g| { let f=&per[find(g)]; if f.is_empty(){None} else { let w:f64=f.iter().map(|x|x.3).sum(); Some(f.iter().map(|x|x.1*x.3).sum::<f64>()/w)} });
    report(&format!("{name} best-snr finger"), gs, &|g| { let f=&per[find(g)]; f.iter().max_by(|a,b|a.3.total_cmp(&b.3)).map(|x|x.1) });
    report(&format!("{name} earliest"), gs, &|g| { let f=&per[find(g)]; f.iter().map(|x|x.1).min_by(f64::total_cmp) });
  }
}
fn confusion(gs:&[G]){
  let st=[S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4)];
  for sh in ["step","linear","smooth"]{ let mut cnt=[0usize;7]; let mut dl=vec![];
    for g in gs.iter().filter(|g|g.right&&g.shape==sh){ for h in g.h.iter().filter(|h|h.1.abs()>=0.5){ let f=fit(&h.2,&st).unwrap(); let k=st.iter().position(|s|format!("{s:?}")==format!("{:?}",f.1)).unwrap(); cnt[k]+=1;
      let s = match sh {"step"=>S::L(0.0),"linear"=>S::L(g.r),_=>S::Sm(g.r)}; let ft=fit(&h.2,&[s]).unwrap(); dl.push(((h.2.len() as f64)*(ft.2/f.2).ln()/2.0)); } }
    let mut d2=dl.clone(); println!("{sh}: chosen {:?}  loglik gap true-vs-best median {:.2}", cnt, med(&mut d2)); }
}
fn windows(gs:&[G]){
  let st=[S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4)];
  let e_of=|s:S,c:f64| c + match s {S::L(r)|S::Sm(r)=>r/2.0, S::P(p,r)=> r - r/p};
  for w in [0.25,0.4,0.6,0.9] {
    for conf in [false,true] {
    report(&format!("window {w} before intercept{}", if conf {" (oracle)"} else {""}), gs, &|g| {
      let ts:Vec<f64>=g.h.iter().filter(|h|h.1.abs()>=0.5).filter_map(|h| { let f=fit(&h.2,&st)?; let e=e_of(f.1,f.0);
         let sub:Vec<(f64,f64)>=h.2.iter().copied().filter(|p|p.0>=e-w).collect();
         let sts:Vec<S> = if conf { vec![match g.shape.as_str(){"step"=>S::L(0.0),"linear"=>S::L(g.r),_=>S::Sm(g.r)}] } else { st.to_vec() };
         fit(&sub,&sts).map(|f|f.0) }).collect(); if ts.is_empty(){None} else {Some(mean(&ts))} });
  } }
}
fn singles(gs:&[G]){
  let mut cands=vec![S::L(0.0)]; for r in [0.05,0.1,0.15,0.2,0.3,0.4]{cands.push(S::L(r));} for r in [0.1,0.2,0.3,0.4,0.5]{cands.push(S::Sm(r));}
  for s in &cands { report(&format!("single {:?}",s), gs, &|g| { let ts:Vec<f64>=g.h.iter().filter(|h|h.1.abs()>=0.5).filter_map(|h|fit(&h.2,&[*s]).map(|f|f.0)).collect(); if ts.is_empty(){None}else{Some(mean(&ts))} }); }
  // BMA over the 7 starts and all candidates: weights exp(-n/2 ln sse) with a temperature
  let st=[S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4)];
  for temp in [1.0, 4.0, 16.0] {
  report(&format!("BMA temp {temp}"), gs, &|g| { let ts:Vec<f64>=g.h.iter().filter(|h|h.1.abs()>=0.5).filter_map(|h| { let n=h.2.len(); if n<8 {return None}
     let mut all=vec![]; for k in 3..n-3 { for &s in &st { if let Some((e,_))=sse(&h.2,h.2[k].0,s){ all.push((e,h.2[k].0)); } } }
     let emin=all.iter().map(|a|a.0).fold(f64::INFINITY,f64::min); let (mut w,mut wt)=(0.0,0.0);
     for a in &all { let q=(-(n as f64)/2.0*(a.0/emin).ln()/temp).exp(); w+=q; wt+=q*a.1; } Some(wt/w) }).collect(); if ts.is_empty(){None}else{Some(mean(&ts))} });
  }
}
fn grid(gs:&[G]){
  let mut pw=vec![S::L(0.0)]; for p in [1.5,2.0,3.0,4.0] { for r in [0.1,0.2,0.3,0.4] { pw.push(S::P(p,r)); } }
  let mut pw3=vec![S::L(0.0)]; for p in [2.0,3.0] { for r in [0.1,0.2,0.3,0.4] { pw3.push(S::P(p,r)); } }
  let mut cub=vec![S::L(0.0)]; for r in [0.1,0.2,0.3,0.4] { cub.push(S::P(3.0,r)); }
  let sets:Vec<(&str,Vec<S>)>=vec![
    ("7",vec![S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4)]),
    ("pow",vec![S::L(0.0),S::P(2.0,0.1),S::P(2.0,0.2),S::P(2.0,0.3),S::P(3.0,0.2),S::P(3.0,0.3),S::P(3.0,0.4)]),
    ("pow2-3x4",pw3), ("pow-all",pw), ("cubic",cub)];
  for (name,st) in &sets {
    let per:Vec<Vec<(usize,f64,S,f64)>> = gs.iter().map(|g| g.h.iter().filter(|h|h.1.abs()>=0.5).filter_map(|h| fit(&h.2,st).map(|f|(h.0,f.0,f.1,snr(&h.2,f.0,f.1)))).collect()).collect();
    let find=|g:&G| gs.iter().position(|x| std::ptr::eq(x,g)).unwrap();
    report(&format!("{name} mean"), gs, &|g| { let f=&per[find(g)]; if f.is_empty(){None} else {Some(mean(&f.iter().map(|x|x.1).collect::<Vec<_>>()))} });
    report(&format!("{name} snr-weighted"), gs, &|g| { let f=&per[find(g)]; if f.is_empty(){None} else { let w:f64=f.iter().map(|x|x.3).sum(); Some(f.iter().map(|x|x.1*x.3).sum::<f64>()/w)} });
  }
}
// drift-aware fit: u = a + g t + b z ; returns (sse, b)
fn sse_d(h:&[(f64,f64)],c:f64,s:S,drift:bool)->Option<(f64,f64)>{ let m=h.len() as f64;
  let (mut sz,mut su,mut st)=(0.0,0.0,0.0); for p in h{sz+=z(s,p.0,c);su+=p.1;st+=p.0}
  let (mz,mu,mt)=(sz/m,su/m,st/m); let (mut szz,mut szu,mut stt,mut stu,mut szt)=(0.0,0.0,0.0,0.0,0.0);
  for p in h{let zz=z(s,p.0,c)-mz; let tt=p.0-mt; let uu=p.1-mu; szz+=zz*zz; szu+=zz*uu; stt+=tt*tt; stu+=tt*uu; szt+=zz*tt;}
  let (b,g)= if drift { let var=szz-szt*szt/stt; if var<=1e-9*szz.max(1e-300){return None}; let b=(szu-szt*stu/stt)/var; (b,(stu-b*szt)/stt) } else { if szz<=0.0{return None}; (szu/szz,0.0) };
  let e=h.iter().map(|p|(p.1-mu-b*(z(s,p.0,c)-mz)-g*(p.0-mt)).powi(2)).sum(); Some((e,b)) }
fn fit_d(h:&[(f64,f64)],s:S,drift:bool)->Option<(f64,f64,f64)>{ let n=h.len(); if n<8{return None}
  let step=((n-6)+255)/256; let mut best:Option<(f64,f64,f64)>=None;
  let mut k=3; while k<n-3 { if let Some((e,b))=sse_d(h,h[k].0,s,drift){ if best.map_or(true,|x|e<x.0){best=Some((e,h[k].0,b))}} k+=step.max(1);} best.map(|x|(x.1,x.0,x.2)) }
fn solve(a:&mut Vec<Vec<f64>>, b:&mut Vec<f64>)->Vec<f64>{ let n=b.len(); for i in 0..n{ let p=(i..n).max_by(|&x,&y|a[x][i].abs().total_cmp(&a[y][i].abs())).unwrap(); a.swap(i,p); b.swap(i,p); for j in i+1..n{ let f=a[j][i]/a[i][i]; for k in i..n{a[j][k]-=f*a[i][k];} b[j]-=f*b[i]; } } let mut x=vec![0.0;n]; for i in (0..n).rev(){ let mut s=b[i]; for k in i+1..n{s-=a[i][k]*x[k];} x[i]=s/a[i][i]; } x }
// ridge LS with per-sample weights; features include intercept as first
fn ls(xs:&[Vec<f64>], ys:&[f64], ws:&[f64], ridge:f64)->Vec<f64>{ let p=xs[0].len(); let mut a=vec![vec![0.0;p];p]; let mut b=vec![0.0;p];
  for ((x,y),w) in xs.iter().zip(ys).zip(ws){ for i in 0..p{ b[i]+=w*x[i]*y; for j in 0..p{a[i][j]+=w*x[i]*x[j];} } }
  for i in 1..p{a[i][i]+=ridge;} solve(&mut a,&mut b) }
fn stack(all:&[G]){
  let gs:Vec<G>=all.iter().filter(|g|g.right).cloned().collect();
  let drift = true;
  let st=[S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::P(3.0,0.2),S::P(3.0,0.3),S::P(3.0,0.4),S::Sm(0.2),S::Sm(0.4)];
  // per grasp: per start: (mean over fingers of t0 - onset_ref) ; use est relative to a reference (decision time) to keep numbers small
  // features: t0_s - dec for each start s (finger mean, weights = clarity), plus best-start t0
  let mut feats:Vec<Vec<f64>>=vec![]; let mut ys=vec![]; let mut shapes=vec![]; let mut seeds=vec![]; let mut best0=vec![];
  for g in &gs { let hs:Vec<&(usize,f64,Vec<(f64,f64)>)>=g.h.iter().filter(|h|h.1.abs()>=0.5).collect(); if hs.is_empty(){continue}
    let mut per=vec![0.0;st.len()]; let mut bestt=0.0; let mut lsse=vec![0.0;st.len()]; let mut speed=0.0;
    for h in &hs { let fs:Vec<(f64,f64,f64)>=st.iter().map(|&s|fit_d(&h.2,s,drift).unwrap()).collect();
      for (i,f) in fs.iter().enumerate(){ per[i]+=(f.0-g.dec)/hs.len() as f64; lsse[i]+=f.1.ln()*h.2.len() as f64/2.0; }
      let bi=(0..st.len()).min_by(|&a,&b|fs[a].1.total_cmp(&fs[b].1)).unwrap(); bestt+=(fs[bi].0-g.dec)/hs.len() as f64; speed+=fs[0].2.abs()/hs.len() as f64; }
    let lmin=lsse.iter().cloned().fold(f64::INFINITY,f64::min);
    let mut x=vec![1.0]; x.extend(per.iter()); // per-start t0
    // soft: loglik gaps
    x.extend(lsse.iter().map(|l|(l-lmin).min(20.0)*0.01));
    x.push(1.0/speed.max(1.0));
    feats.push(x); ys.push(g.onset-g.dec); shapes.push(g.shape.clone()); seeds.push(g.seed); best0.push(bestt);
  }
  let nsh=|s:&str| shapes.iter().filter(|x|*x==s).count() as f64;
  let ws:Vec<f64>=shapes.iter().map(|s|1.0/nsh(s)).collect();
  let score=|name:&str, pred:&dyn Fn(usize)->f64| { let mut line=format!("{name:50}"); let mut worst:f64=0.0; let mut wm:f64=0.0;
    for sh in ["step","linear","smooth"]{ let e:Vec<f64>=(0..ys.len()).filter(|&i|shapes[i]==sh).map(|i|pred(i)-ys[i]).collect(); let mut a:Vec<f64>=e.iter().map(|x|x.abs()).collect(); let m=med(&mut a); let mn=mean(&e); worst=worst.max(m); wm=wm.max(mn.abs()); line+=&format!(" {sh} {:.0}/{:+.0}",m*1e3,mn*1e3);} println!("{line} | worst {:.0}/{:.0}",worst*1e3,wm*1e3); };
  let lead=mean(&(0..ys.len()).map(|i|best0[i]-ys[i]).collect::<Vec<_>>());
  score("best start, lead", &|i| best0[i]-lead);
  // subsets of features
  let sets:Vec<(&str,Vec<usize>)>=vec![
    ("t0 per start",(0..1+st.len()).collect()),
    ("t0 per start + gaps",(0..1+2*st.len()).collect()),
    ("t0 per start + gaps + 1/v",(0..2+2*st.len()).collect()),
    ("t0 step+lin0.3+cub0.4",vec![0,1,4,7]),
    ("t0 step+lin0.3+cub0.4 + 1/v",vec![0,1,4,7,1+2*st.len()]),
  ];
  for (name,idx) in &sets { for ridge in [0.0, 1e-3] {
    let sub=|i:usize| idx.iter().map(|&k|feats[i][k]).collect::<Vec<f64>>();
    let xs:Vec<Vec<f64>>=(0..ys.len()).map(sub).collect();
    let beta=ls(&xs,&ys,&ws,ridge);
    score(&format!("{name} r{ridge} in-sample"), &|i| xs[i].iter().zip(&beta).map(|(a,b)|a*b).sum());
    // 5-fold CV over seeds
    let mut pred=vec![0.0;ys.len()];
    for f in 0..5u64 { let tr:Vec<usize>=(0..ys.len()).filter(|&i|seeds[i]%5!=f).collect();
      let b=ls(&tr.iter().map(|&i|xs[i].clone()).collect::<Vec<_>>(), &tr.iter().map(|&i|ys[i]).collect::<Vec<_>>(), &tr.iter().map(|&i|ws[i]).collect::<Vec<_>>(), ridge);
      for i in (0..ys.len()).filter(|&i|seeds[i]%5==f){ pred[i]=xs[i].iter().zip(&b).map(|(a,b)|a*b).sum(); } }
    score(&format!("{name} r{ridge} 5-fold CV"), &|i| pred[i]);
  } }
}
fn penalty(all:&[G]){
  let gs:Vec<G>=all.iter().filter(|g|g.right).cloned().collect();
  let st=[S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::P(3.0,0.2),S::P(3.0,0.3),S::P(3.0,0.4)];
  let lag=|s:S| match s {S::L(r)|S::Sm(r)=>r/2.0, S::P(p,r)=> r - r/p};
  // per grasp per finger: per start (t0, sse), n, C
  let fits:Vec<Vec<(usize,f64,Vec<(f64,f64)>)>>=gs.iter().map(|g| g.h.iter().filter(|h|h.1.abs()>=0.5).map(|h|{
     let n=h.2.len(); let m=h.2.iter().map(|p|p.1).sum::<f64>()/n as f64; let c:f64=h.2.iter().map(|p|(p.1-m).powi(2)).sum();
     (n,c,st.iter().map(|&s|{let f=fit_d(&h.2,s,true).unwrap(); (f.0,f.1)}).collect())}).collect()).collect();
  for mode in ["len","lag"] { for kappa in [-4.0,-2.0,-1.0,0.0,1.0,2.0,3.0,4.0,6.0,10.0] {
    let est:Vec<Option<f64>>=fits.iter().map(|f|{ if f.is_empty(){return None}
      let (mut ws,mut wt)=(0.0,0.0);
      let joint = std::env::var("JOINT").is_ok();
      let kj=(0..st.len()).min_by(|&a,&b|{ let la:f64=f.iter().map(|(n,_,v)|(*n as f64)/2.0*v[a].1.ln()).sum(); let lb:f64=f.iter().map(|(n,_,v)|(*n as f64)/2.0*v[b].1.ln()).sum(); let pa=match st[a]{S::L(r)|S::Sm(r)|S::P(_,r)=>r}; let pb=match st[b]{S::L(r)|S::Sm(r)|S::P(_,r)=>r}; (la+kappa*pa/0.1).total_cmp(&(lb+kappa*pb/0.1))}).unwrap();
      for (n,c,v) in f { let k= if joint {kj} else {(0..st.len()).min_by(|&a,&b|{ let pa=if mode=="len"{match st[a]{S::L(r)|S::Sm(r)|S::P(_,r)=>r}}else{lag(st[a])}; let pb=if mode=="len"{match st[b]{S::L(r)|S::Sm(r)|S::P(_,r)=>r}}else{lag(st[b])};
          ((*n as f64)/2.0*v[a].1.ln()+kappa*pa/0.1).total_cmp(&((*n as f64)/2.0*v[b].1.ln()+kappa*pb/0.1))}).unwrap()};
        let e=v[k].1; let w=((c-e)/e).max(0.0); ws+=w; wt+=w*v[k].0; }
      Some(wt/ws) }).collect();
    let errs:Vec<f64>=gs.iter().zip(&est).filter_map(|(g,e)|e.map(|e|e-g.onset)).collect(); let lead=mean(&errs);
    let mut line=format!("{mode} kappa {kappa:5} lead {:+.0}:",lead*1e3); let (mut w1,mut w2):(f64,f64)=(0.0,0.0);
    for sh in ["step","linear","smooth"]{ let e:Vec<f64>=gs.iter().zip(&est).filter(|(g,_)|g.shape==sh).filter_map(|(g,e)|e.map(|e|e-g.onset-lead)).collect(); let mut a:Vec<f64>=e.iter().map(|x|x.abs()).collect(); let m=med(&mut a); let mn=mean(&e); w1=w1.max(m); w2=w2.max(mn.abs()); line+=&format!(" {sh} {:.0}/{:+.0}",m*1e3,mn*1e3); }
    println!("{line} | worst {:.0}/{:.0}",w1*1e3,w2*1e3);
  } }
}

// (stop 32) two fingers in one likelihood. Per moving finger k and start s, the ramp-hinge profile
// log-likelihood ℓ_k(c, s) = −n_k/2 · ln SSE_k(c, s) on one time grid (finger histories share
// their frame times); shared: ℓ(c, s) = Σ_k ℓ_k(c, s). Estimators: argmax; posterior mean of c with
// weights exp((ℓ − ℓmax)/T); split test: separate change points when
// max ℓ_1 + max ℓ_2 − max_shared ℓ > P (then the earliest of the separate estimates).
// Two-finger oracles: told the true start (and, `oracle+lag`, each finger's true offset).
fn joint(all:&[G]){
  let gs:Vec<G>=all.iter().filter(|g|g.right).cloned().collect();
  // the stage's `linear_cubic` starts, or (START_SET=fine) the family's own shapes on a fine grid,
  // or (START_SET=smooth) the stage's `linear_smooth` starts
  let st:Vec<S>=match std::env::var("START_SET").as_deref() {
    Ok("fine") => { let mut v=vec![S::L(0.0)]; for r in [0.05,0.1,0.15,0.2,0.25,0.3]{v.push(S::L(r));} for r in [0.1,0.15,0.2,0.25,0.3,0.35,0.4]{v.push(S::Sm(r));} v }
    Ok("lc05") => vec![S::L(0.0),S::L(0.05),S::L(0.1),S::L(0.2),S::L(0.3),S::P(3.0,0.2),S::P(3.0,0.3),S::P(3.0,0.4)],
    Ok("lc05n") => vec![S::L(0.05),S::L(0.1),S::L(0.2),S::L(0.3),S::P(3.0,0.2),S::P(3.0,0.3),S::P(3.0,0.4)],
    Ok("smooth") => vec![S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::Sm(0.2),S::Sm(0.3),S::Sm(0.4)],
    _ => vec![S::L(0.0),S::L(0.1),S::L(0.2),S::L(0.3),S::P(3.0,0.2),S::P(3.0,0.3),S::P(3.0,0.4)] };
  // per grasp: grid times, per finger: (k, n, per start: Vec<ℓ over grid>)
  struct J{ grid:Vec<f64>, f:Vec<(usize,f64,Vec<Vec<f64>>)> }
  let js:Vec<J>=gs.iter().map(|g|{
    let hs:Vec<&(usize,f64,Vec<(f64,f64)>)>=g.h.iter().filter(|h|h.1.abs()>=0.5 && h.2.len()>=8).collect();
    if hs.is_empty(){ return J{grid:vec![],f:vec![]} }
    // grid: the union's span, 10 ms steps, leaving 3 points at either end of the shortest
    let lo=hs.iter().map(|h|h.2[3].0).fold(f64::NEG_INFINITY,f64::max);
    let hi=hs.iter().map(|h|h.2[h.2.len()-4].0).fold(f64::INFINITY,f64::min);
    let mut grid=vec![]; let mut t=lo; while t<=hi+1e-9 { grid.push(t); t+=0.01; }
    let f=hs.iter().map(|h|{ let n=h.2.len() as f64;
      (h.0, n, st.iter().map(|&s| grid.iter().map(|&c| sse_d(&h.2,c,s,true).map_or(f64::NEG_INFINITY,|(e,_)| -n/2.0*e.max(1e-300).ln())).collect()).collect()) }).collect();
    J{grid,f} }).collect();
  let amax=|v:&[f64]| (0..v.len()).max_by(|&a,&b|v[a].total_cmp(&v[b])).unwrap();
  // per-finger estimate (argmax or posterior mean) over its own ℓ
  let post=|grid:&[f64], l:&Vec<Vec<f64>>, temp:f64| -> f64 { let m=l.iter().flatten().cloned().fold(f64::NEG_INFINITY,f64::max);
    if temp<=0.0 { let mut best=(f64::NEG_INFINITY,0.0); for ls in l { for (i,&x) in ls.iter().enumerate(){ if x>best.0 {best=(x,grid[i]);} } } return best.1 }
    let (mut w,mut wt)=(0.0,0.0); for ls in l { for (i,&x) in ls.iter().enumerate(){ let q=((x-m)/temp).exp(); w+=q; wt+=q*grid[i]; } } wt/w };
  let shared=|j:&J| -> Vec<Vec<f64>> { (0..st.len()).map(|s| (0..j.grid.len()).map(|i| j.f.iter().map(|f|f.2[s][i]).sum()).collect()).collect() };
  let rep=|name:&str, est:&dyn Fn(&G,&J)->Option<f64>| {
    let e:Vec<Option<f64>>=gs.iter().zip(&js).map(|(g,j)| if j.f.is_empty(){None} else {est(g,j)}).collect();
    let errs:Vec<f64>=gs.iter().zip(&e).filter_map(|(g,e)|e.map(|e|e-g.onset)).collect(); let lead=mean(&errs);
    let mut line=format!("{name:44} lead {:+4.0}:",lead*1e3); let (mut w1,mut w2):(f64,f64)=(0.0,0.0);
    for sh in ["step","linear","smooth"]{ let v:Vec<f64>=gs.iter().zip(&e).filter(|(g,_)|g.shape==sh).filter_map(|(g,e)|e.map(|e|e-g.onset-lead)).collect(); let mut a:Vec<f64>=v.iter().map(|x|x.abs()).collect(); let m=med(&mut a); let mn=mean(&v); w1=w1.max(m); w2=w2.max(mn.abs()); line+=&format!(" {sh} {:.0}/{:+.0}",m*1e3,mn*1e3); }
    for (nm,lagged) in [("1st",true),("tog",false)] { let v:Vec<f64>=gs.iter().zip(&e).filter(|(g,_)|(g.lag>0.0)==lagged).filter_map(|(g,e)|e.map(|e|e-g.onset-lead)).collect(); let mut a:Vec<f64>=v.iter().map(|x|x.abs()).collect(); line+=&format!(" {nm} {:.0}/{:+.0}",med(&mut a)*1e3,mean(&v)*1e3); }
    let mut a:Vec<f64>=errs.iter().map(|x|(x-lead).abs()).collect();
    println!("{line} | all {:.0} | worst {:.0}/{:.0}",med(&mut a)*1e3,w1*1e3,w2*1e3); (w1,w2) };
  let clear=|g:&G,j:&J,temp:f64| -> Option<f64> { // per-finger estimates, earliest
    j.f.iter().map(|f| post(&j.grid,&f.2,temp)).min_by(f64::total_cmp) };
  // the stage's clear_earliest (gate × the clearest finger's (C − E)/E) over per-finger posterior means
  let cw=|g:&G,j:&J,temp:f64,gate:f64| -> Option<f64> { let hs=gs_h(g);
    let v:Vec<(f64,f64)>=j.f.iter().zip(&hs).map(|(f,h)|{ let n=h.2.len() as f64; let m=h.2.iter().map(|p|p.1).sum::<f64>()/n; let c:f64=h.2.iter().map(|p|(p.1-m).powi(2)).sum();
      let lmax=f.2.iter().flatten().cloned().fold(f64::NEG_INFINITY,f64::max); let e=(-2.0*lmax/n).exp(); (post(&j.grid,&f.2,temp), ((c-e)/e).max(0.0)) }).collect();
    let top=v.iter().map(|x|x.1).fold(0.0,f64::max); v.iter().filter(|x|x.1>=gate*top).map(|x|x.0).min_by(f64::total_cmp) };
  for temp in [0.0,0.5,1.0,2.0,4.0,8.0] { for gate in [0.2,0.35,0.5] { rep(&format!("per finger T{temp} clear_earliest {gate}"), &|g,j| cw(g,j,temp,gate)); } }
  // (c) a lead per fitted start of the chosen finger (and per fingers' spread), learned by 5-fold CV
  // over seeds: the default's estimate minus its fold's mean signed error in the same bin
  let feat=|g:&G,j:&J| -> Option<(f64,usize,f64)> { let hs=gs_h(g);
    let v:Vec<(f64,f64,usize)>=j.f.iter().zip(&hs).map(|(f,h)|{ let n=h.2.len() as f64; let m=h.2.iter().map(|p|p.1).sum::<f64>()/n; let c:f64=h.2.iter().map(|p|(p.1-m).powi(2)).sum();
      let mut b=(f64::NEG_INFINITY,0,0); for (s,l) in f.2.iter().enumerate(){ for (i,&x) in l.iter().enumerate(){ if x>b.0 {b=(x,s,i);} } }
      let e=(-2.0*b.0/n).exp(); (j.grid[b.2], ((c-e)/e).max(0.0), b.1) }).collect();
    let top=v.iter().map(|x|x.1).fold(0.0,f64::max);
    let sel=v.iter().filter(|x|x.1>=0.35*top).min_by(|a,b|a.0.total_cmp(&b.0))?;
    let spread=v.iter().map(|x|x.0).fold(f64::NEG_INFINITY,f64::max)-v.iter().map(|x|x.0).fold(f64::INFINITY,f64::min);
    Some((sel.0, sel.2, spread)) };
  let fs:Vec<Option<(f64,usize,f64)>>=gs.iter().zip(&js).map(|(g,j)| if j.f.is_empty(){None} else {feat(g,j)}).collect();
  for (name,nb,bin) in [("per start",st.len(),Box::new(|f:&(f64,usize,f64)| f.1) as Box<dyn Fn(&(f64,usize,f64))->usize>),
      ("per start kind (3)",3,Box::new(|f:&(f64,usize,f64)| match f.1 {0=>0,1..=3=>1,_=>2})),
      ("per kind × spread<50ms",6,Box::new(|f:&(f64,usize,f64)| match f.1 {0=>0,1..=3=>1,_=>2}*2 + usize::from(f.2<0.05))),
      ("per spread<50ms",2,Box::new(|f:&(f64,usize,f64)| usize::from(f.2<0.05)))] {
    let mut pred=vec![None;gs.len()];
    for fold in 0..5u64 { let mut sum=vec![0.0;nb]; let mut cnt=vec![0.0;nb];
      for (i,g) in gs.iter().enumerate(){ if g.seed%5==fold {continue} if let Some(f)=&fs[i]{ sum[bin(f)]+=f.0-g.onset; cnt[bin(f)]+=1.0; } }
      for (i,g) in gs.iter().enumerate(){ if g.seed%5!=fold {continue} if let Some(f)=&fs[i]{ let b=bin(f); pred[i]=Some(f.0 - if cnt[b]>0.0 {sum[b]/cnt[b]} else {0.0}); } } }
    let idx=|g:&G| gs.iter().position(|x| std::ptr::eq(x,g)).unwrap();
    rep(&format!("default + lead {name}, 5-fold CV"), &|g,_j| pred[idx(g)]);
  }
  // merge when close: both fingers' change points within δ → the shared fit's c (or their mean);
  // else the default's clear_earliest
  for d in [0.02,0.04,0.06,0.08,0.1,0.15] { for shared_c in [false,true] {
    rep(&format!("merge within {d} s ({})", if shared_c {"shared fit"} else {"mean"}), &|g,j| { let hs=gs_h(g);
      let v:Vec<(f64,f64)>=j.f.iter().zip(&hs).map(|(f,h)|{ let n=h.2.len() as f64; let m=h.2.iter().map(|p|p.1).sum::<f64>()/n; let c:f64=h.2.iter().map(|p|(p.1-m).powi(2)).sum();
        let lmax=f.2.iter().flatten().cloned().fold(f64::NEG_INFINITY,f64::max); let e=(-2.0*lmax/n).exp(); (post(&j.grid,&f.2,0.0), ((c-e)/e).max(0.0)) }).collect();
      let top=v.iter().map(|x|x.1).fold(0.0,f64::max);
      let sel:Vec<f64>=v.iter().filter(|x|x.1>=0.35*top).map(|x|x.0).collect();
      if v.len()==2 && (v[0].0-v[1].0).abs()<d { if shared_c { Some(post(&j.grid,&shared(j),0.0)) } else { Some((v[0].0+v[1].0)/2.0) } }
      else { sel.into_iter().min_by(f64::total_cmp) } }); } }
  // CONFIRM=1 (stop 32): the confirmatory run on fresh tuning-side seeds (400..800, never looked
  // at before this rule was committed). RULE, stated before the run: the candidates below, each
  // with its own lead, ranked by the worst start shape's median |error|, then its |mean
  // signed|; a candidate wins only if it ranks first AND its worst median is at least 3 ms
  // below the default's with a worst |mean| no larger. A winner goes into the stage, is
  // re-ranked by `slip_eval -- tune` and scored once on the held-out seeds; otherwise nothing
  // changes and no held-out seed is scored.
  if std::env::var("CONFIRM").is_ok() {
    let split=|g:&G,j:&J,temp:f64,pen:f64| -> Option<f64> { let sh=shared(j); let lsh=sh.iter().flatten().cloned().fold(f64::NEG_INFINITY,f64::max);
      let lsep:f64=j.f.iter().map(|f| f.2.iter().flatten().cloned().fold(f64::NEG_INFINITY,f64::max)).sum();
      if j.f.len()==2 && lsep-lsh>pen { clear(g,j,temp) } else { Some(post(&j.grid,&sh,temp)) } };
    let merge=|g:&G,j:&J,d:f64| -> Option<f64> { let hs=gs_h(g);
      let v:Vec<(f64,f64)>=j.f.iter().zip(&hs).map(|(f,h)|{ let n=h.2.len() as f64; let m=h.2.iter().map(|p|p.1).sum::<f64>()/n; let c:f64=h.2.iter().map(|p|(p.1-m).powi(2)).sum();
        let lmax=f.2.iter().flatten().cloned().fold(f64::NEG_INFINITY,f64::max); let e=(-2.0*lmax/n).exp(); (post(&j.grid,&f.2,0.0), ((c-e)/e).max(0.0)) }).collect();
      let top=v.iter().map(|x|x.1).fold(0.0,f64::max);
      if v.len()==2 && (v[0].0-v[1].0).abs()<d { Some(post(&j.grid,&shared(j),0.0)) } else { v.iter().filter(|x|x.1>=0.35*top).map(|x|x.0).min_by(f64::total_cmp) } };
    let mut rows:Vec<(String,(f64,f64))>=vec![];
    rows.push(("default (argmax, clear_earliest 0.35)".into(), rep("default", &|g,j| cw(g,j,0.0,0.35))));
    rows.push(("(a) shared".into(), rep("(a) shared", &|_g,j| Some(post(&j.grid,&shared(j),0.0)))));
    rows.push(("(a) shared, split P5".into(), rep("(a) split P5", &|g,j| split(g,j,0.0,5.0))));
    rows.push(("(a) shared, split P20".into(), rep("(a) split P20", &|g,j| split(g,j,0.0,20.0))));
    rows.push(("(a)+(b) split P20, T2".into(), rep("(a)+(b) P20 T2", &|g,j| split(g,j,2.0,20.0))));
    rows.push(("(a)+(b) split P20, T4".into(), rep("(a)+(b) P20 T4", &|g,j| split(g,j,4.0,20.0))));
    rows.push(("(b) per finger T1, clear_earliest 0.35".into(), rep("(b) T1", &|g,j| cw(g,j,1.0,0.35))));
    rows.push(("merge within 0.1 s (shared fit)".into(), rep("merge 0.1", &|g,j| merge(g,j,0.1))));
    let def=rows[0].1;
    rows.sort_by(|a,b| a.1.0.total_cmp(&b.1.0).then(a.1.1.total_cmp(&b.1.1)));
    println!("ranked (worst median / worst |mean|, ms):");
    for r in &rows { println!("  {:44} {:.0} / {:.0}", r.0, r.1.0*1e3, r.1.1*1e3); }
    let top=&rows[0];
    let wins=!top.0.starts_with("default") && top.1.0 <= def.0-0.003 && top.1.1 <= def.1;
    println!("verdict: {}", if wins { format!("{} wins", top.0) } else { "no candidate wins; the default stays".into() });
    return;
  }
  for temp in [0.0,1.0,2.0,4.0,8.0,16.0,32.0] {
    rep(&format!("per finger T{temp} earliest"), &|g,j| clear(g,j,temp));
    rep(&format!("per finger T{temp} mean"), &|g,j| Some(mean(&j.f.iter().map(|f| post(&j.grid,&f.2,temp)).collect::<Vec<_>>())));
    rep(&format!("shared T{temp}"), &|g,j| Some(post(&j.grid,&shared(j),temp)));
    for pen in [0.0,2.0,5.0,10.0,20.0] {
      rep(&format!("shared T{temp} split P{pen}"), &|g,j| { let sh=shared(j); let lsh=sh.iter().flatten().cloned().fold(f64::NEG_INFINITY,f64::max);
        let lsep:f64=j.f.iter().map(|f| f.2.iter().flatten().cloned().fold(f64::NEG_INFINITY,f64::max)).sum();
        if j.f.len()==2 && lsep-lsh>pen { clear(g,j,temp) } else { Some(post(&j.grid,&sh,temp)) } });
    }
  }
  // shape pooled over the fingers: per start s, shared ℓ(s) = max_c Σ_k ℓ_k(c, s) and separate
  // ℓ(s) = Σ_k max_c ℓ_k(c, s) (one finger first); model (s, shared|separate) by ℓ − P·[separate];
  // separate: the earliest finger's c. `oracle`: s told.
  let pooled=|g:&G,j:&J,pen:f64,only:Option<usize>| -> Option<f64> {
    let mut best=(f64::NEG_INFINITY,0.0);
    for s in 0..st.len() { if only.is_some_and(|o|o!=s) {continue}
      let sh:Vec<f64>=(0..j.grid.len()).map(|i| j.f.iter().map(|f|f.2[s][i]).sum()).collect(); let i=amax(&sh);
      if sh[i]>best.0 { best=(sh[i], j.grid[i]); }
      if j.f.len()==2 { let l:f64=j.f.iter().map(|f| f.2[s][amax(&f.2[s])]).sum::<f64>()-pen;
        if l>best.0 { best=(l, j.f.iter().map(|f| j.grid[amax(&f.2[s])]).fold(f64::INFINITY,f64::min)); } } }
    Some(best.1) };
  for pen in [0.0,1.0,2.0,3.0,5.0,8.0,12.0,20.0,1e9] { rep(&format!("pooled shape, split P{pen}"), &|g,j| pooled(g,j,pen,None)); }
  // told the start: the nearest start of the set (linear r → L(r) nearest; smooth → cubic nearest r)
  let near=|g:&G| -> usize { match g.shape.as_str(){"step"=>0, "linear"=> [0.1,0.2,0.3].iter().enumerate().min_by(|a,b|(a.1-g.r).abs().total_cmp(&(b.1-g.r).abs())).unwrap().0+1, _=> [0.2,0.3,0.4].iter().enumerate().min_by(|a,b|(a.1-g.r).abs().total_cmp(&(b.1-g.r).abs())).unwrap().0+4 } };
  for pen in [0.0,2.0,5.0,1e9] { rep(&format!("oracle nearest start, pooled split P{pen}"), &|g,j| pooled(g,j,pen,Some(near(g)))); }
  // oracles (need the true start; the grid of the same sse_d)
  let truth=|g:&G| match g.shape.as_str(){"step"=>S::L(0.0),"linear"=>S::L(g.r),_=>S::Sm(g.r)};
  // told the exact start; one change point or two (one finger first) chosen by ℓ − P·[two]
  for pen in [0.0,2.0,5.0,10.0,1e9] { rep(&format!("oracle true start, split P{pen}"), &|g,j| {
    let ls:Vec<Vec<f64>>=gs_h(g).iter().map(|h|{ let n=h.2.len() as f64; j.grid.iter().map(|&c| sse_d(&h.2,c,truth(g),true).map_or(f64::NEG_INFINITY,|(e,_)| -n/2.0*e.max(1e-300).ln())).collect()}).collect();
    let sh:Vec<f64>=(0..j.grid.len()).map(|i| ls.iter().map(|l|l[i]).sum()).collect(); let i=amax(&sh);
    let mut best=(sh[i],j.grid[i]);
    if ls.len()==2 { let l:f64=ls.iter().map(|l|l[amax(l)]).sum::<f64>()-pen; if l>best.0 { best=(l, ls.iter().map(|l|j.grid[amax(l)]).fold(f64::INFINITY,f64::min)); } }
    Some(best.1) }); }
  // told each finger's true offset (not the start): shared c + offsets, starts of the set
  rep("oracle true lags, starts unknown (argmax)", &|g,j| { let hs=gs_h(g); let mut best=(f64::NEG_INFINITY,0.0);
    for &s in &st { for &c in &j.grid { let mut l=0.0; for h in &hs { let off=g.fon[h.0]-g.onset; let n=h.2.len() as f64;
      match sse_d(&h.2,c+off,s,true){ Some((e,_))=> l+= -n/2.0*e.max(1e-300).ln(), None=>{l=f64::NEG_INFINITY} } } if l>best.0 {best=(l,c);} } } Some(best.1) });
  // which start kind the two-finger (shared-shape, separate change points) likelihood picks, per
  // true shape, and its log-likelihood margin over the best start of another kind
  let kind=|s:S| match s { S::L(r) if r==0.0 => 0usize, S::L(_) => 1, _ => 2 };
  for sh in ["step","linear","smooth"] { let mut cnt=[0usize;3]; let mut gaps=vec![];
    for (g,j) in gs.iter().zip(&js).filter(|(g,j)|g.shape==sh && !j.f.is_empty()) {
      let per_kind:Vec<f64>=(0..3).map(|kd| (0..st.len()).filter(|&s|kind(st[s])==kd).map(|s| j.f.iter().map(|f| f.2[s][amax(&f.2[s])]).sum::<f64>()).fold(f64::NEG_INFINITY,f64::max)).collect();
      let b=amax(&per_kind); cnt[b]+=1; let tk=match sh {"step"=>0,"linear"=>1,_=>2};
      gaps.push(per_kind[b]-per_kind[tk]); }
    println!("{sh}: two-finger likelihood picks sudden/linear/{} {:?}; true kind's log-lik below the best: median {:.1}", if matches!(st[st.len()-1],S::P(..)) {"cubic"} else {"smooth"}, cnt, med(&mut gaps)); }
  rep("oracle per finger true start, earliest", &|g,j| { gs_h(g).iter().filter_map(|h| fit_d(&h.2,truth(g),true).map(|f|f.0)).min_by(f64::total_cmp) });
  rep("oracle per finger true start, mean", &|g,j| { let v:Vec<f64>=gs_h(g).iter().filter_map(|h| fit_d(&h.2,truth(g),true).map(|f|f.0)).collect(); if v.is_empty(){None}else{Some(mean(&v))} });
  for (name,withlag) in [("oracle shared true start",false),("oracle shared true start + true lags",true)] {
    rep(name, &|g,j| { let hs=gs_h(g); let mut best=(f64::NEG_INFINITY,0.0);
      for &c in &j.grid { let mut l=0.0; for h in &hs { let off= if withlag { g.fon[h.0]-g.onset } else {0.0}; let n=h.2.len() as f64;
          match sse_d(&h.2,c+off,truth(g),true){ Some((e,_))=> l+= -n/2.0*e.max(1e-300).ln(), None=>{l=f64::NEG_INFINITY} } }
        if l>best.0 {best=(l,c);} } Some(best.1) });
  }
}
fn gs_h(g:&G)->Vec<&(usize,f64,Vec<(f64,f64)>)>{ g.h.iter().filter(|h|h.1.abs()>=0.5 && h.2.len()>=8).collect() }
