//! Reads Gaussian files through the one loader and prints, per file, the
//! count, SH degree and the wall time of the read (the file is read from
//! the page cache: run it once before timing). Used by
//! `scripts/bench_splat_formats.sh`.
//!
//! ```text
//! cargo run --release --example read_splats -- FILE...
//! ```

use std::path::Path;
use std::time::Instant;

fn main() {
    let mut failed = false;
    for f in std::env::args().skip(1) {
        let t = Instant::now();
        match splatkit::io::any::load_gaussians(Path::new(&f), "read_splats") {
            Ok(g) => println!(
                "{{\"file\":{f:?},\"gaussians\":{},\"sh_degree\":{},\"seconds\":{:.3}}}",
                g.len(),
                g.sh_degree,
                t.elapsed().as_secs_f64()
            ),
            Err(e) => {
                eprintln!("error: {e}");
                failed = true;
            }
        }
    }
    std::process::exit(i32::from(failed));
}
