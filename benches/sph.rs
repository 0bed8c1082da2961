//! SPH step throughput at the thesis's particle counts (2 675 / 8 486 / 14 010, its Table 6.1
//! configurations S = 10 / 8 / 4) and at 50 000: a block of water collapsing in a tank
//! ([`rain_composite::fluid::scenes::collapsing_block`]), warmed up for 20 steps.
//!
//! `cargo bench --bench sph`; steps per second = 1 / (time per iteration).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use rain_composite::fluid::scenes::collapsing_block;
use std::time::Duration;

fn sph_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("sph_step");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    for n in [2_675usize, 8_486, 14_010, 50_000] {
        let mut sph = collapsing_block(n).expect("benchmark scene");
        for _ in 0..20 {
            sph.step();
        }
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| std::hint::black_box(sph.step()))
        });
    }
    group.finish();
}

criterion_group!(benches, sph_step);
criterion_main!(benches);
