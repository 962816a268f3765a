//! Sizes of a firmware ELF: its allocated sections (what goes to flash and
//! to RAM) and the code by crate, from the symbol table.
//!
//! The per-crate split is approximate by nature: with LTO, code inlined into
//! a function counts for the crate of the function it was inlined into, and
//! generic code for the crate that named the symbol (`<T as Trait>::f` is
//! counted for the crate of `T` when it is one of ours).

use object::{Object, ObjectSection, ObjectSymbol, SectionKind, SymbolKind};
use std::collections::BTreeMap;

/// One section: name, size, kind of memory.
pub struct Section {
    /// Section name.
    pub name: String,
    /// Bytes.
    pub size: u64,
    /// Flash (loaded: code, constants, `.data`'s initial values) or RAM only.
    pub in_flash: bool,
    /// Occupies RAM at run time.
    pub in_ram: bool,
}

/// What `sizes` reports.
pub struct Sizes {
    /// Allocated sections.
    pub sections: Vec<Section>,
    /// Code bytes (function symbols) by crate.
    pub code_by_crate: BTreeMap<String, u64>,
}

const BUILTINS: &str = "compiler_builtins (soft-float, mem*, 64-bit division)";

impl Sizes {
    /// (bytes in flash, bytes of static RAM).
    pub fn totals(&self) -> (u64, u64) {
        let flash = self.sections.iter().filter(|s| s.in_flash).map(|s| s.size).sum();
        let ram = self.sections.iter().filter(|s| s.in_ram).map(|s| s.size).sum();
        (flash, ram)
    }
}

/// The crate a (demangled) symbol belongs to: the first `name::` path in
/// it (`<[f64; 2] as core::fmt::Debug>::fmt` is core's); C-ABI names are
/// compiler_builtins' (`__addsf3` …) or the start-up code's.
fn crate_of(demangled: &str, raw: &str) -> String {
    let bytes = demangled.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let starts = (c.is_ascii_alphabetic() || c == b'_') && (i == 0 || !is_ident(bytes[i - 1]));
        if starts {
            let end = (i..bytes.len()).find(|&j| !is_ident(bytes[j])).unwrap_or(bytes.len());
            if demangled[end..].starts_with("::") {
                let name = &demangled[i..end];
                return match name {
                    "compiler_builtins" => BUILTINS.to_owned(),
                    // The panic / allocation shims rustc generates.
                    "__rustc" => "core".to_owned(),
                    _ => name.to_owned(),
                };
            }
            i = end;
        } else {
            i += 1;
        }
    }
    if raw.starts_with("_ZN") || raw.starts_with("_R") {
        // A method of a primitive type (`<char>::escape_debug_ext`).
        return "core".to_owned();
    }
    if raw.starts_with("__") || matches!(raw, "memcpy" | "memset" | "memmove" | "memcmp" | "bcmp") {
        return BUILTINS.to_owned();
    }
    if raw == "main" {
        // `#[riscv_rt::entry]`'s function: the binary's own code.
        return "main (the binary's own, with what was inlined into it)".to_owned();
    }
    "C and assembly symbols (Espressif's WiFi/PHY blobs, start-up, traps)".to_owned()
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// Whether `addr` is in the ESP32-C3's internal SRAM (its data bus window
/// 0x3FC8_0000.. or its instruction bus window 0x4037_C000..): code there
/// (`.rwtext`, `.trap`) is loaded from the image into RAM at boot.
fn esp32c3_sram(addr: u64) -> bool {
    (0x3FC8_0000..0x3FCE_0000).contains(&addr) || (0x4037_C000..0x403E_0000).contains(&addr)
}

/// Reads `elf`.
pub fn sizes(elf: &[u8]) -> Result<Sizes, object::Error> {
    let file = object::File::parse(elf)?;
    let mut sections = vec![];
    for s in file.sections() {
        let name = s.name().unwrap_or("?").to_owned();
        let (alloc, nobits) = match s.flags() {
            object::SectionFlags::Elf { sh_flags } => (
                sh_flags & u64::from(object::elf::SHF_ALLOC) != 0,
                matches!(s.kind(), SectionKind::UninitializedData | SectionKind::UninitializedTls),
            ),
            _ => (false, false),
        };
        // riscv-rt's `.stack`/`.heap` and esp-hal's `*_dummy` sections only
        // reserve address space.
        let placeholder =
            name == ".stack" || name == ".heap" || name == ".text.dummy" || name.ends_with("_dummy");
        if !alloc || s.size() == 0 || placeholder {
            continue;
        }
        let (in_flash, in_ram) = if nobits {
            (false, true)
        } else {
            // Loaded from the image; also in RAM when its contents are
            // copied there (initialised data) or it runs from internal RAM.
            (true, matches!(s.kind(), SectionKind::Data | SectionKind::Tls) || esp32c3_sram(s.address()))
        };
        sections.push(Section { name, size: s.size(), in_flash, in_ram });
    }
    let mut code_by_crate = BTreeMap::new();
    for sym in file.symbols() {
        if sym.kind() != SymbolKind::Text || sym.size() == 0 {
            continue;
        }
        let raw = sym.name().unwrap_or("");
        let demangled = format!("{:#}", rustc_demangle::demangle(raw));
        *code_by_crate.entry(crate_of(&demangled, raw)).or_insert(0) += sym.size();
    }
    Ok(Sizes { sections, code_by_crate })
}

/// The report as text lines.
pub fn report(name: &str, s: &Sizes) -> String {
    let mut out = format!("sizes of {name}:\n");
    for sec in &s.sections {
        let place = match (sec.in_flash, sec.in_ram) {
            (true, true) => "flash (initial values) + RAM",
            (true, false) => "flash",
            _ => "RAM",
        };
        out += &format!("  {:<18} {:>8} B  {place}\n", sec.name, sec.size);
    }
    let (flash, ram) = s.totals();
    out += &format!("  total: {flash} B in the image (flash), {ram} B of static RAM (stack not included)\n");
    out += "  code by crate (function symbols; inlined code counts for its caller):\n";
    let mut by: Vec<_> = s.code_by_crate.iter().collect();
    by.sort_by(|a, b| b.1.cmp(a.1));
    for (krate, bytes) in by {
        out += &format!("    {krate:<52} {bytes:>8} B\n");
    }
    out
}
