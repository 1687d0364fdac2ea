//! Generates the equations of `mbs_symbolic::samples::planar_chain(n)` for every `n` in the
//! environment variable `PEERS_NS` (space- or comma-separated, default `2 4 8`) with the
//! project's emitter, all parameters folded (the sample has no run-time parameters), and a
//! dispatcher `chains::run(n, ...)` plus the emitter's operation counts.

use std::fmt::Write as _;
use std::path::PathBuf;

use mbs_symbolic::emit::{EmitOptions, generate, write_if_changed};
use mbs_symbolic::samples::planar_chain;

fn main() {
    println!("cargo:rerun-if-env-changed=PEERS_NS");
    println!("cargo:rerun-if-changed=build.rs");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR is set by cargo"));
    let spec = std::env::var("PEERS_NS").unwrap_or_else(|_| "2 4 8".into());
    let mut ns: Vec<usize> = spec
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse()
                .expect("PEERS_NS: chain sizes must be positive integers")
        })
        .collect();
    ns.sort_unstable();
    ns.dedup();
    assert!(
        ns.iter().all(|&n| n > 0),
        "PEERS_NS: chain sizes must be positive"
    );

    let mut chains = String::new();
    let mut arms = String::new();
    let mut stats = String::new();
    for &n in &ns {
        let model = planar_chain(n);
        assert!(
            model.parameters.iter().all(|p| !p.runtime),
            "planar_chain({n}) has run-time parameters: they would not be folded"
        );
        let opts = EmitOptions {
            struct_name: Some(format!("Chain{n}")),
            ..Default::default()
        };
        let generated = generate(&model, &opts).expect("the planar chain generates");
        let file = format!("chain_{n}.rs");
        write_if_changed(&out_dir.join(&file), &generated.source).expect("write generated code");
        let _ = writeln!(
            chains,
            "#[allow(dead_code)]\nmod chain_{n} {{ include!(concat!(env!(\"OUT_DIR\"), \"/{file}\")); }}"
        );
        let _ = writeln!(
            arms,
            "        {n} => crate::bench::run::<{n}, chain_{n}::Chain{n}>(args),"
        );
        for (name, c) in &generated.stats {
            let _ = writeln!(
                stats,
                "    ({n}, {name:?}, [{}, {}, {}, {}, {}]),",
                c.adds, c.muls, c.divs, c.funcs, c.negs
            );
        }
    }
    let src = format!(
        "{chains}\n\
         /// Chain sizes generated at build time (`PEERS_NS`).\n\
         pub const SIZES: &[usize] = &{ns:?};\n\n\
         /// The emitter's operation counts: (n, function, [adds, muls, divs, funcs, negs]).\n\
         pub const STATS: &[(usize, &str, [usize; 5])] = &[\n{stats}];\n\n\
         /// Runs the benchmark for the chain of `n` links; `false` if it was not generated.\n\
         pub fn run(n: usize, args: &crate::bench::Args) -> bool {{\n    \
             match n {{\n{arms}        _ => return false,\n    }}\n    true\n}}\n"
    );
    write_if_changed(&out_dir.join("chains.rs"), &src).expect("write dispatcher");
}
