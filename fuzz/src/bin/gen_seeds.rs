#![no_main]
#![allow(unreachable_code)] // the init hook exits
//! Writes the seed corpora: `gen_seeds <golden fixtures dir> <corpus dir>` creates
//! `<corpus dir>/<target>/seed_<name>` for every seed of `handgate_fuzz::seeds`, then exits.
//! It is built as a (no-op) fuzz target so that `cargo fuzz build` links it like the others;
//! the work happens in libFuzzer's initialisation hook, before any fuzzing.
libfuzzer_sys::fuzz_target!(
    init: {
        let args: Vec<String> = std::env::args().collect();
        if args.len() != 3 {
            eprintln!("usage: gen_seeds <golden fixtures dir> <corpus dir>");
            std::process::exit(2);
        }
        let seeds = handgate_fuzz::seeds(std::path::Path::new(&args[1]));
        let n = seeds.len();
        for (target, name, bytes) in seeds {
            let dir = std::path::Path::new(&args[2]).join(target);
            std::fs::create_dir_all(&dir).expect("create corpus dir");
            std::fs::write(dir.join(format!("seed_{name}")), bytes).expect("write seed");
        }
        println!("gen_seeds: {n} seeds");
        std::process::exit(0);
    },
    |_data: &[u8]| {}
);
