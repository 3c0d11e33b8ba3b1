//! Host throughput of the controller and of the whole pipeline
//! (`cargo bench -p fuzzy-core`). Cost on the Cortex-M4 target is measured
//! in instructions by the firmware's QEMU benchmark.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fuzzy_core::fuzzy::Scratch;
use fuzzy_core::lin2021::{Lin2021Controller, CONTROLLER};
use fuzzy_core::scheduler::{PathPoint, Scheduler, SchedulerConfig};
use fuzzy_core::units::{FeedMmPerMin, Fx, Point3Mm};
use std::hint::black_box;

/// 1000 inputs spread over the controller's domain.
fn inputs() -> Vec<[Fx; 2]> {
    (0..1000)
        .map(|i| {
            [
                Fx::from_num((i % 100) as f64 * 0.031),
                Fx::from_num((i / 100) as f64 * 0.11),
            ]
        })
        .collect()
}

/// A 2001-point lemniscate of 50 mm (similar to the paper's ∞ shape).
fn path() -> Vec<PathPoint> {
    (0..=2000)
        .map(|i| {
            let t = i as f64 / 2000.0 * std::f64::consts::TAU;
            let d = 1.0 + t.sin().powi(2);
            PathPoint::at(
                Point3Mm::from_f64(50.0 * t.cos() / d, 50.0 * t.sin() * t.cos() / d, 0.0).unwrap(),
            )
        })
        .collect()
}

fn controller(c: &mut Criterion) {
    let xs = inputs();
    let mut g = c.benchmark_group("controller");
    g.throughput(Throughput::Elements(xs.len() as u64));
    let mut scratch = Scratch::new();
    g.bench_function("lin2021 exact centroid (fast path)", |b| {
        b.iter(|| {
            xs.iter()
                .map(|x| {
                    CONTROLLER
                        .evaluate_with(&mut scratch, black_box(*x))
                        .output
                        .to_bits() as i64
                })
                .sum::<i64>()
        })
    });
    g.bench_function("lin2021 101-sample centroid (MATLAB)", |b| {
        b.iter(|| {
            xs.iter()
                .map(|x| CONTROLLER.evaluate_sampled(black_box(*x)).output.to_bits() as i64)
                .sum::<i64>()
        })
    });
    g.finish();
}

fn pipeline(c: &mut Criterion) {
    let pts = path();
    let mut g = c.benchmark_group("scheduler");
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("lin2021 WS=30 AVG=9, 2001-point lemniscate", |b| {
        b.iter(|| {
            let cfg =
                SchedulerConfig::new(FeedMmPerMin::from_int(3000), FeedMmPerMin::from_int(60));
            let mut s: Scheduler<&Lin2021Controller, 30, 9, 40> =
                Scheduler::new(&CONTROLLER, cfg).unwrap();
            let mut sum = 0i64;
            s.run(black_box(&pts).iter().copied(), |p| {
                sum += p.feed.0.to_bits()
            })
            .unwrap();
            sum
        })
    });
    g.finish();
}

criterion_group!(benches, controller, pipeline);
criterion_main!(benches);
