//! `make bench`: the road under the four wheels over 10 s at 1 kHz (what the road FMU computes
//! for a 10 s co-simulation), for the ISO class C road sampled on its grid, summed directly, and
//! for the bump.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use vehicle::road::{Profile, Road, Side};

fn ten_seconds(c: &mut Criterion, name: &str, road: &Road, exact: bool) {
    c.bench_function(name, |b| {
        b.iter(|| {
            // A fresh road each time: the sampled one computes its blocks as it goes.
            let road = road.clone();
            let mut sum = 0.0;
            for k in 0..10_000 {
                let t = k as f64 * 1e-3;
                if exact {
                    let s = road.speed * t - road.start_distance;
                    for (track, d) in [(0, 0.0), (1, 0.0), (0, road.wheelbase), (1, road.wheelbase)]
                    {
                        sum += road.track_exact(track, s - d).0;
                    }
                } else {
                    sum += road.at(t)[0];
                }
            }
            black_box(sum)
        })
    });
}

fn bench(c: &mut Criterion) {
    let iso = Road::new(
        Profile::Iso {
            class: 3,
            seed: 1,
            identical_tracks: false,
            fade_in: 0.0,
        },
        20.0,
        2.4,
        0.0,
    )
    .unwrap();
    let bump = Road::new(
        Profile::Bump {
            height: 0.05,
            length: 5.0,
            side: Side::Left,
        },
        20.0,
        2.4,
        5.0,
    )
    .unwrap();
    ten_seconds(c, "road_iso_c_10s_1khz_sampled", &iso, false);
    ten_seconds(c, "road_iso_c_10s_1khz_direct_sum", &iso, true);
    ten_seconds(c, "road_bump_10s_1khz", &bump, false);
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
