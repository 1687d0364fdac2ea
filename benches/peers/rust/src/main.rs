//! The project's side of the peer benchmark (see `benches/peers/README.md`).
//!
//! `peers-rust <n> <states.bin> [--check K] [--secs S] [--reps R]` loads the state sequence
//! written by `run.py` (little-endian `f64`, per state `q[0..n]` then `q'[0..n]`) and prints,
//! one record per line:
//!
//! - `ops <function> <total> <adds> <muls> <divs> <funcs> <negs>`: the emitter's counts;
//! - `check <k> <M row-major> <F>`: `M^b` and `F^b` at the first `K` states (shortest
//!   round-trip decimal), for `run.py` to compare with the C code before any timing;
//! - `time fused <ns>` and `time separate <ns>`: nanoseconds per evaluation, median of `R`
//!   repetitions of about `S` seconds each, of the fused `evaluate` (`M`, `F`, `Q`, `h`, `J`,
//!   `A`) and of `mass_matrix` followed by `f_vector`.

mod bench;
mod chains;

fn main() {
    let args = match bench::Args::parse(std::env::args().skip(1)) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("peers-rust: {e}");
            eprintln!("usage: peers-rust <n> <states.bin> [--check K] [--secs S] [--reps R]");
            std::process::exit(2);
        }
    };
    for (n, name, [adds, muls, divs, funcs, negs]) in chains::STATS {
        if *n == args.n {
            let total = adds + muls + divs + funcs + negs;
            println!("ops {name} {total} {adds} {muls} {divs} {funcs} {negs}");
        }
    }
    if !chains::run(args.n, &args) {
        eprintln!(
            "peers-rust: chain size {} was not generated (built with PEERS_NS = {:?})",
            args.n,
            chains::SIZES
        );
        std::process::exit(2);
    }
}
