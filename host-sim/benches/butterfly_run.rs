//! The whole host-sim run on the paper's 2001-point butterfly: fuzzy-core's
//! schedule, the FANUC-like machine (interpolation + acc/dec), contour error
//! and kinematics (`cargo bench -p host-sim`). Target: well under 50 ms.

use criterion::{criterion_group, criterion_main, Criterion};
use host_sim::config::SimConfig;
use host_sim::experiments::dat_phuc2024::fanuc::FanucMode;
use host_sim::machine::MachineConfig;
use host_sim::methods::Method;
use host_sim::shapes::Shape;
use host_sim::simulate::{self, Prepared};
use std::hint::black_box;

fn butterfly(c: &mut Criterion) {
    let path = Shape::Butterfly.toolpath().unwrap();
    let mut g = c.benchmark_group("butterfly 2001 points, F_max 3000 mm/min");
    g.sample_size(20);
    let conventional = SimConfig::default();
    g.bench_function("fuzzy + fanuc conventional + metrics (incl. index)", |b| {
        b.iter(|| {
            let p = Prepared::new(black_box(path.clone()));
            simulate::run(&p, Method::Fuzzy, 3000.0, &conventional)
                .unwrap()
                .metrics
        })
    });
    let mut high = SimConfig::default();
    if let MachineConfig::Fanuc(f) = &mut high.machine {
        f.mode = FanucMode::HighAccuracy;
    }
    g.bench_function("fuzzy + fanuc high-accuracy + metrics", |b| {
        let p = Prepared::new(path.clone());
        b.iter(|| {
            simulate::run(&p, Method::Fuzzy, 3000.0, &high)
                .unwrap()
                .metrics
        })
    });
    let servo = SimConfig {
        machine: MachineConfig::ServoXy(Default::default()),
        ..Default::default()
    };
    g.bench_function("fuzzy + servo-xy + metrics", |b| {
        let p = Prepared::new(path.clone());
        b.iter(|| {
            simulate::run(&p, Method::Fuzzy, 3000.0, &servo)
                .unwrap()
                .metrics
        })
    });
    g.finish();
}

criterion_group!(benches, butterfly);
criterion_main!(benches);
