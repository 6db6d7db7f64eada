//! Reading a confocal z-stack: 1024 x 1024 x 100 16-bit slices (200 MiB of samples),
//! written once to the system temp directory by this crate's ImageJ writer, then streamed
//! slice by slice. Throughput is reported in bytes of sample data per second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flakescatter_io::stack::{
    ImageJStackWriter, SampleType, StackLayout, StackOptions, StackReader,
};

const N: usize = 1024;
const NZ: usize = 100;

fn bench_read(c: &mut Criterion) {
    let path = std::env::temp_dir().join(format!(
        "flakescatter-bench-stack-{}.tif",
        std::process::id()
    ));
    let layout = StackLayout {
        nx: N,
        ny: N,
        nz: NZ,
        dx_um: 0.18,
        dy_um: 0.18,
        dz_um: 0.3,
        sample: SampleType::U16,
    };
    let mut w = ImageJStackWriter::create(&path, layout).unwrap();
    for k in 0..NZ {
        let slice: Vec<u16> = (0..N * N)
            .map(|i| ((i * 31 + k * 977) % 65536) as u16)
            .collect();
        w.write_u16(&slice).unwrap();
    }
    w.finish().unwrap();

    let mut g = c.benchmark_group("read_stack");
    g.sample_size(10);
    g.throughput(Throughput::Bytes((N * N * NZ * 2) as u64));
    g.bench_function("imagej_1024x1024x100_u16", |b| {
        b.iter(|| {
            let mut r = StackReader::open(&path, &StackOptions::default()).unwrap();
            let mut sum = 0.0f64;
            while let Some(s) = r.next_slice().unwrap() {
                sum += f64::from(s[s.len() / 2]);
            }
            sum
        });
    });
    g.finish();
    let _ = std::fs::remove_file(&path);
}

criterion_group!(benches, bench_read);
criterion_main!(benches);
