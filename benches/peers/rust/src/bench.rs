//! The correctness dump and the timing loops, generic over the chain size.

use std::hint::black_box;
use std::time::Instant;

use mbs_symbolic::runtime::{Evaluation, Mechanism};

/// Command-line arguments.
pub struct Args {
    /// Number of links.
    pub n: usize,
    /// The state sequence, `2 n` values per state.
    pub states: Vec<f64>,
    /// Number of states whose `M`, `F` are printed for the agreement check.
    pub check: usize,
    /// Target duration of one timed repetition, seconds.
    pub secs: f64,
    /// Number of timed repetitions (the median is reported).
    pub reps: usize,
}

impl Args {
    /// Parses `<n> <states.bin> [--check K] [--secs S] [--reps R]`.
    pub fn parse(mut it: impl Iterator<Item = String>) -> Result<Args, String> {
        let n: usize = it
            .next()
            .ok_or("missing <n>")?
            .parse()
            .map_err(|e| format!("<n>: {e}"))?;
        let path = it.next().ok_or("missing <states.bin>")?;
        let bytes = std::fs::read(&path).map_err(|e| format!("{path}: {e}"))?;
        if n == 0 || bytes.is_empty() || bytes.len() % (16 * n) != 0 {
            return Err(format!(
                "{path}: {} bytes is not a whole number of states of {n} links",
                bytes.len()
            ));
        }
        let states = bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("chunks of 8 bytes")))
            .collect();
        let mut args = Args {
            n,
            states,
            check: 4,
            secs: 0.5,
            reps: 5,
        };
        while let Some(flag) = it.next() {
            let value = it.next().ok_or(format!("{flag} needs a value"))?;
            let bad = |e: &dyn std::fmt::Display| format!("{flag} {value}: {e}");
            match flag.as_str() {
                "--check" => args.check = value.parse().map_err(|e| bad(&e))?,
                "--secs" => args.secs = value.parse().map_err(|e| bad(&e))?,
                "--reps" => args.reps = value.parse().map_err(|e| bad(&e))?,
                _ => return Err(format!("unknown option {flag}")),
            }
        }
        if args.reps == 0 || args.secs.is_nan() || args.secs <= 0.0 {
            return Err("--reps and --secs must be positive".into());
        }
        Ok(args)
    }
}

/// Splits the flat state sequence into `(q, q')` pairs.
fn states<const N: usize>(flat: &[f64]) -> Vec<([f64; N], [f64; N])> {
    flat.chunks_exact(2 * N)
        .map(|s| {
            (
                std::array::from_fn(|i| s[i]),
                std::array::from_fn(|i| s[N + i]),
            )
        })
        .collect()
}

/// Nanoseconds per evaluation: `pass` evaluates every state once; the number of passes per
/// repetition is calibrated to about `secs`; the median over `reps` repetitions.
fn time(n_states: usize, secs: f64, reps: usize, mut pass: impl FnMut()) -> f64 {
    // Warm up and calibrate.
    let mut passes = 1usize;
    loop {
        let t = Instant::now();
        for _ in 0..passes {
            pass();
        }
        let dt = t.elapsed().as_secs_f64();
        if dt > 0.05 {
            passes = ((passes as f64) * secs / dt).ceil() as usize;
            break;
        }
        passes *= 4;
    }
    let mut ns: Vec<f64> = (0..reps)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..passes {
                pass();
            }
            t.elapsed().as_secs_f64() * 1e9 / (passes * n_states) as f64
        })
        .collect();
    ns.sort_by(f64::total_cmp);
    ns[reps / 2]
}

/// Prints the check records and the two timings for the chain `C` of `N` links.
pub fn run<const N: usize, C: Mechanism<N, 0> + Default>(args: &Args) {
    let chain = C::default();
    let states = states::<N>(&args.states);

    let mut out = Evaluation::<N, 0>::default();
    for (k, (q, qd)) in states.iter().take(args.check).enumerate() {
        chain.evaluate(q, qd, 0.0, &mut out);
        // The separate methods must give the same numbers (the emitter promises bit-identity).
        let mut m = [[0.0; N]; N];
        let mut f = [0.0; N];
        chain.mass_matrix(q, &mut m);
        chain.f_vector(q, qd, &mut f);
        assert!(
            m == out.mass && f == out.f,
            "fused and separate evaluations differ"
        );
        let vals: Vec<String> = out
            .mass
            .iter()
            .flatten()
            .chain(&out.f)
            .map(|v| format!("{v:e}"))
            .collect();
        println!("check {k} {}", vals.join(" "));
    }

    let fused = time(states.len(), args.secs, args.reps, || {
        for (q, qd) in &states {
            chain.evaluate(black_box(q), black_box(qd), black_box(0.0), &mut out);
            black_box(&mut out);
        }
    });
    println!("time fused {fused}");

    let mut m = [[0.0; N]; N];
    let mut f = [0.0; N];
    let separate = time(states.len(), args.secs, args.reps, || {
        for (q, qd) in &states {
            chain.mass_matrix(black_box(q), &mut m);
            chain.f_vector(black_box(q), black_box(qd), &mut f);
            black_box(&mut m);
            black_box(&mut f);
        }
    });
    println!("time separate {separate}");
}
