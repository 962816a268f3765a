//! PROTOCOL.md's message layouts, traced from the message types.
//!
//! Why `serde-reflection` and not a table kept by hand: the bus encodes
//! with postcard, which writes exactly what serde's derive walks (an enum's
//! variant index, then its fields in declaration order), so the traced
//! format *is* the wire layout; a field added, moved or renamed changes the
//! table, and the docs test fails until it is committed.

use bycoms_protocol::msg::{Deploy, Refusal};
use bycoms_protocol::msg::{DriveState, FromAgent, GateEvent, GateKind, Pose, RobotKind, Sensor, ToAgent};
use serde_reflection::{ContainerFormat, Format, Named, Registry, Tracer, TracerConfig, VariantFormat};

/// The messages of PROTOCOL.md §5, in its order, each with where it
/// travels; then the enums their fields name.
const MESSAGES: [(&str, &str); 6] = [
    ("ToAgent", "topic `robot/<id>/to_agent`"),
    ("FromAgent", "topic `robot/<id>/from_agent`"),
    ("Pose", "topic `robot/<id>/pose`"),
    ("Sensor", "topic `robot/<id>/sensor`"),
    ("GateEvent", "topic `gate`"),
    ("Deploy", "topic `operator`"),
];
const FIELD_ENUMS: [&str; 4] = ["Refusal", "RobotKind", "DriveState", "GateKind"];

fn registry() -> Registry {
    let mut tracer = Tracer::new(TracerConfig::default());
    let traced = [
        tracer.trace_simple_type::<ToAgent>().map(drop),
        tracer.trace_simple_type::<FromAgent>().map(drop),
        tracer.trace_simple_type::<Pose>().map(drop),
        tracer.trace_simple_type::<Sensor>().map(drop),
        tracer.trace_simple_type::<GateEvent>().map(drop),
        tracer.trace_simple_type::<Deploy>().map(drop),
        tracer.trace_simple_type::<Refusal>().map(drop),
        tracer.trace_simple_type::<RobotKind>().map(drop),
        tracer.trace_simple_type::<DriveState>().map(drop),
        tracer.trace_simple_type::<GateKind>().map(drop),
    ];
    for t in traced {
        t.unwrap_or_else(|e| panic!("tracing the messages: {e}"));
    }
    tracer.registry().unwrap_or_else(|e| panic!("the messages' registry: {e}"))
}

/// A field's type as Rust writes it.
fn type_of(format: &Format) -> String {
    match format {
        Format::TypeName(name) => name.clone(),
        Format::Unit => "()".into(),
        Format::Bool => "bool".into(),
        Format::U8 => "u8".into(),
        Format::U16 => "u16".into(),
        Format::U32 => "u32".into(),
        Format::U64 => "u64".into(),
        Format::I8 => "i8".into(),
        Format::I16 => "i16".into(),
        Format::I32 => "i32".into(),
        Format::I64 => "i64".into(),
        Format::F32 => "f32".into(),
        Format::F64 => "f64".into(),
        Format::Str => "String".into(),
        Format::Option(inner) => format!("Option<{}>", type_of(inner)),
        Format::Seq(inner) => format!("Vec<{}>", type_of(inner)),
        Format::TupleArray { content, size } => format!("[{}; {size}]", type_of(content)),
        other => format!("{other:?}"),
    }
}

fn fields(fields: &[Named<Format>]) -> String {
    fields.iter().map(|f| format!("`{}: {}`", f.name, type_of(&f.value))).collect::<Vec<_>>().join(", ")
}

/// A variant's fields; a newtype variant of a struct is that struct's
/// fields (postcard writes them right after the index).
fn variant_fields(variant: &VariantFormat, registry: &Registry) -> String {
    match variant {
        VariantFormat::Unit => "—".into(),
        VariantFormat::Struct(named) => fields(named),
        VariantFormat::NewType(inner) => match inner.as_ref() {
            Format::TypeName(name) => match registry.get(name) {
                Some(ContainerFormat::Struct(named)) => format!("{} (a `{name}`)", fields(named)),
                _ => format!("`{name}`"),
            },
            other => format!("`{}`", type_of(other)),
        },
        VariantFormat::Tuple(items) => {
            items.iter().map(|f| format!("`{}`", type_of(f))).collect::<Vec<_>>().join(", ")
        }
        VariantFormat::Variable(_) => unreachable!("a traced registry has no variables"),
    }
}

fn container(name: &str, registry: &Registry) -> String {
    match registry.get(name) {
        Some(ContainerFormat::Struct(named)) => format!("A struct, no variant index: {}.", fields(named)),
        Some(ContainerFormat::NewTypeStruct(inner)) => format!("Its `{}`, as is.", type_of(inner)),
        Some(ContainerFormat::Enum(variants)) => {
            let mut rows = vec!["| index | variant | fields |".to_string(), "|---|---|---|".to_string()];
            for (index, v) in variants {
                rows.push(format!("| {index} | `{}` | {} |", v.name, variant_fields(&v.value, registry)));
            }
            rows.join("\n")
        }
        other => panic!("{name}: not a message the table knows how to show: {other:?}"),
    }
}

/// The region's text: a heading and a layout per message, then per enum
/// that a field names.
pub fn tables() -> String {
    let registry = registry();
    let mut out = Vec::new();
    for (name, place) in MESSAGES {
        out.push(format!("#### `{name}` ({place})\n\n{}\n", container(name, &registry)));
    }
    for name in FIELD_ENUMS {
        out.push(format!("#### `{name}` (a field's enum)\n\n{}\n", container(name, &registry)));
    }
    out.join("\n")
}

#[test]
fn a_layout_names_every_variant_in_index_order_with_its_fields() {
    let table = container("ToAgent", &registry());
    let rows: Vec<&str> = table.lines().skip(2).collect();
    assert!(
        rows[0].starts_with("| 0 | `Deploy` | `robot: RobotId`, `x: f64`, `y: f64`, `heading: f64`"),
        "{}",
        rows[0]
    );
    assert!(rows.iter().any(|r| r.starts_with("| 3 | `Stop` | — |")), "{table}");
    let robot = container("Pose", &registry());
    assert!(robot.contains("`time_us: u64`"), "{robot}");
}
