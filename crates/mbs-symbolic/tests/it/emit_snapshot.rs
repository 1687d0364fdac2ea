//! The emitter's output, pinned: a snapshot (insta) of the generated source of the small
//! `models/pendulum.json`, and the handling of awkward names (Rust keywords, non-ASCII
//! characters, dashes and spaces, names differing only in case).
//!
//! The snapshot lives in `tests/snapshots/` and is committed; CI (`CI=true`) never writes
//! snapshots, so a change of the emitted code fails there until the new snapshot is
//! reviewed (`INSTA_UPDATE=always cargo test -p mbs-symbolic --test emit_snapshot`, or
//! `cargo insta review`) and committed.

use std::path::PathBuf;

use mbs_symbolic::emit::{EmitError, EmitOptions, GENERATOR_VERSION, generate};
use mbs_symbolic::model::{self, Format, Model};

fn workspace_file(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
}

fn parse_toml(src: &str) -> Model {
    model::parse_str(src, "awkward.toml", Format::Toml).unwrap_or_else(|e| panic!("{e}"))
}

/// Generates and checks that the source parses as a Rust file.
fn generate_parsed(model: &Model, opts: &EmitOptions) -> (String, syn::File) {
    let g = generate(model, opts).unwrap_or_else(|e| panic!("{e}"));
    let file = syn::parse_file(&g.source).unwrap_or_else(|e| panic!("{e}\n{}", g.source));
    (g.source, file)
}

/// Names of the fields of the generated struct.
fn field_names(file: &syn::File, struct_name: &str) -> Vec<String> {
    file.items
        .iter()
        .find_map(|item| match item {
            syn::Item::Struct(s) if s.ident == struct_name => Some(
                s.fields
                    .iter()
                    .filter_map(|f| f.ident.as_ref().map(ToString::to_string))
                    .collect(),
            ),
            _ => None,
        })
        .unwrap_or_else(|| panic!("no struct {struct_name}"))
}

#[test]
fn pendulum_source_snapshot() {
    let model =
        model::load(&workspace_file("models/pendulum.json")).unwrap_or_else(|e| panic!("{e}"));
    let (source, _) = generate_parsed(&model, &EmitOptions::default());
    // The header carries the generator version and the model file's content hash: neither
    // is about the emitted code (the hash changes with the file's description text or line
    // endings), so both are replaced by placeholders before comparing.
    let version_and_hash = format!(
        "mbs-symbolic {GENERATOR_VERSION} from `pendulum.json` (content FNV-1a 64: {})",
        model.source.hash
    );
    assert!(source.contains(&version_and_hash), "{source}");
    let source = source.replace(
        &version_and_hash,
        "mbs-symbolic <version> from `pendulum.json` (content FNV-1a 64: <hash>)",
    );
    insta::assert_snapshot!("pendulum_generated_source", source);
}

/// Parameter names that are Rust keywords or contain non-ASCII letters are sanitised into
/// valid identifiers (`type` -> `type_`, `self` -> `self_`, `ü1` -> `_1`) while the names the
/// user sees (`PARAM_NAMES`, `set_param`) stay as written; a model name with dashes and
/// spaces becomes an UpperCamelCase struct name; odd point names give valid method names.
#[test]
fn awkward_names_are_sanitised_into_valid_identifiers() {
    let model = parse_toml(
        r#"
name = "my weird-model 2"
gravity = [0, "-g", 0]

[parameters]
type = { value = 1.0, runtime = true }
self = { value = 0.5, runtime = true }
Self = { value = 2.0, runtime = true }
"ü1" = { value = 0.1, runtime = true }
_ = { value = 0.2, runtime = true }
g = { value = 9.81, runtime = true }
fn = 0.3

[[bodies]]
name = "rod"
joint = "R3"
mass = "type"
com = ["self * fn", 0, "ü1 + _"]
inertia = { yy = "Self", zz = "Self" }

[[points]]
name = "tip end!"
body = "rod"
position = ["self", 0, 0]

[[points]]
name = "match"
body = "rod"
position = [0, "fn", 0]
"#,
    );
    let (source, file) = generate_parsed(&model, &EmitOptions::default());
    // The run-time parameters, then the private cache of parameter-only subexpressions.
    assert_eq!(
        field_names(&file, "MyWeirdModel2"),
        ["type_", "self_", "Self_", "_1", "__", "g", "hoisted"]
    );
    assert!(
        source.contains(
            r#"PARAM_NAMES: [&'static str; 6] = ["type", "self", "Self", "ü1", "_", "g"]"#
        ),
        "{source}"
    );
    assert!(source.contains(r#""ü1" => self._1 = value"#), "{source}");
    assert!(source.contains("pub fn point_tip_end_("), "{source}");
    assert!(source.contains("pub fn point_match("), "{source}");
    // The folded `fn` is a number in the code, not an identifier.
    assert!(!source.contains("self.fn"), "{source}");

    // A model named like a prelude item still gets a usable struct (the generated code
    // names the `Default` trait by its full path).
    let mut named_default = model.clone();
    named_default.name = "default".into();
    let (source, file) = generate_parsed(&named_default, &EmitOptions::default());
    assert!(
        source.contains("impl ::core::default::Default for Default"),
        "{source}"
    );
    assert_eq!(field_names(&file, "Default").len(), 7);

    // A parameter named like the cache field pushes the cache to another name.
    let mut cache_clash = model.clone();
    cache_clash.parameters[0].name = "hoisted".into();
    let (_, file) = generate_parsed(&cache_clash, &EmitOptions::default());
    assert_eq!(
        field_names(&file, "MyWeirdModel2"),
        ["hoisted", "self_", "Self_", "_1", "__", "g", "hoisted_"]
    );

    // Struct names: sanitised from odd model names, validated when given explicitly.
    for (name, want) in [
        ("123", "M123"),
        ("--", "M"),
        ("été", "T"),
        ("self", "Self_"),
    ] {
        let mut m = model.clone();
        m.name = name.into();
        let g = generate(&m, &EmitOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(g.struct_name, want, "model name {name:?}");
        syn::parse_file(&g.source).unwrap_or_else(|e| panic!("{name:?}: {e}"));
    }
    for bad in ["fn", "Self", "r#Foo", "1X", "a-b", "", "_", "Ünï"] {
        let opts = EmitOptions {
            struct_name: Some(bad.into()),
            ..EmitOptions::default()
        };
        match generate(&model, &opts) {
            Err(EmitError::StructName { name }) => assert_eq!(name, bad),
            other => panic!("struct name {bad:?}: expected StructName error, got {other:?}"),
        }
    }
}

/// Names that sanitise to the same identifier are an `IdentClash` naming both.
#[test]
fn clashing_names_fail_with_ident_clash() {
    let base = r#"
[[bodies]]
name = "rod"
joint = "R3"
mass = 1
"#;
    // Points differing only in case become the same method `point_tip`.
    let points = parse_toml(&format!(
        "{base}
[[points]]
name = \"Tip\"
body = \"rod\"

[[points]]
name = \"tip\"
body = \"rod\"
"
    ));
    match generate(&points, &EmitOptions::default()) {
        Err(EmitError::IdentClash {
            file,
            what,
            a,
            b,
            ident,
        }) => {
            assert_eq!(
                (file.as_str(), what, a.as_str(), b.as_str(), ident.as_str()),
                ("awkward.toml", "points", "Tip", "tip", "point_tip")
            );
        }
        other => panic!("expected IdentClash, got {other:?}"),
    }
    // Run-time parameters `type` and `type_` would both be the field `type_`; two
    // non-ASCII names both become `__`.
    for (params, a, b, ident) in [
        (
            "type = { value = 1, runtime = true }\ntype_ = { value = 2, runtime = true }",
            "type",
            "type_",
            "type_",
        ),
        (
            "\"α\" = { value = 1, runtime = true }\n\"β\" = { value = 2, runtime = true }",
            "α",
            "β",
            "__",
        ),
    ] {
        let m = parse_toml(&format!("[parameters]\n{params}\n{base}"));
        let err = generate(&m, &EmitOptions::default()).unwrap_err();
        assert!(
            matches!(&err, EmitError::IdentClash { what: "parameters", a: x, b: y, ident: z, .. }
                if x == a && y == b && z == ident),
            "{err:?}"
        );
        let msg = err.to_string();
        assert!(
            msg.contains(a) && msg.contains(b) && msg.contains(ident),
            "{msg}"
        );
    }
    // Folded parameters never become identifiers, so they cannot clash.
    let folded = parse_toml(&format!("[parameters]\ntype = 1\ntype_ = 2\n{base}"));
    generate_parsed(&folded, &EmitOptions::default());
}

/// `write_if_changed` writes new content, skips identical content, and on failure leaves
/// neither the target nor its temporary file behind.
#[test]
fn write_if_changed_is_all_or_nothing() {
    use mbs_symbolic::emit::write_if_changed;
    let dir = std::env::temp_dir().join(format!("mbs-emit-write-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("m.rs");
    assert!(write_if_changed(&out, "a").unwrap());
    assert!(!write_if_changed(&out, "a").unwrap());
    assert!(write_if_changed(&out, "b").unwrap());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "b");
    // The rename onto a (non-empty) directory fails after the temporary file was written.
    let target = dir.join("sub");
    std::fs::create_dir_all(target.join("inner")).unwrap();
    let err = write_if_changed(&target, "c").unwrap_err();
    assert!(matches!(err, EmitError::Io { .. }), "{err:?}");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["m.rs", "sub"], "no temporary file left");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The 32-body spatial chain (the generation-time benchmark of the issue): byte-identical
/// across runs (the bodies are written on several threads), valid Rust, no code line over
/// 100 columns. Prints the in-process generation time (not asserted: timing is not a test).
#[test]
fn large_models_generate_deterministically_as_valid_formatted_rust() {
    let model = mbs_symbolic::samples::spatial_chain(32);
    let start = std::time::Instant::now();
    let a = generate(&model, &EmitOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "spatial_chain(32): generated {} bytes in {:?}",
        a.source.len(),
        start.elapsed()
    );
    let b = generate(&model, &EmitOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(a.source == b.source, "two runs differ");
    syn::parse_file(&a.source).unwrap_or_else(|e| panic!("{e}"));
    let long: Vec<&str> = a
        .source
        .lines()
        .filter(|l| !l.starts_with("//") && l.len() > 100)
        .collect();
    assert!(long.is_empty(), "{long:?}");
    assert!(!a.source.contains("__mbs_body!"), "a body marker was left");
}
