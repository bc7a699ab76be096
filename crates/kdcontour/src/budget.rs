//! The memory budget: one value, set once per command (or per plugin), that every
//! loader and every grid and world build checks its size against before it
//! allocates: a volume's voxels after inflation, a mesh's elements, a grid's
//! samples and tree, all the chunks of a world together.
//!
//! A [`Budget`] travels in [`crate::Settings::memory_budget`] to the builds and
//! is passed to the `*_within` loaders of [`crate::io`]; what one step holds when
//! the next starts (a loaded volume while its grid is built) is taken off with
//! [`Budget::less`], so the budget covers the whole command, not each step alone.

pub use crate::error::Size;
use crate::error::{Error, Result};
use std::fmt;

/// The default memory budget in bytes (4 GiB); see [`Budget::DEFAULT`].
pub const DEFAULT_MEMORY_BUDGET: u64 = 4 << 30;

/// The most bytes a command, load or build may allocate. Parses from `4GiB`,
/// `512MB`, `1073741824` (see [`Budget::parse`]); the default is 4 GiB.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Budget(u64);

impl Budget {
    /// The default budget, [`DEFAULT_MEMORY_BUDGET`] (4 GiB).
    pub const DEFAULT: Budget = Budget(DEFAULT_MEMORY_BUDGET);

    /// A budget of `bytes` bytes (0 refuses everything).
    pub const fn bytes(bytes: u64) -> Budget {
        Budget(bytes)
    }

    /// The budget in bytes.
    pub const fn get(self) -> u64 {
        self.0
    }

    /// What is left once `held` bytes are spent (0 at least): the budget of the
    /// next step of a command while the previous step's result is kept.
    pub const fn less(self, held: u64) -> Budget {
        Budget(self.0.saturating_sub(held))
    }

    /// Refuses `needed` bytes for `what` when they exceed the budget, before
    /// anything is allocated ([`Error::TooLarge`]).
    pub fn check(self, what: impl Into<String>, needed: u64) -> Result<()> {
        check_budget(what, needed, self)
    }

    /// Parses a size: a positive number of bytes, whole or decimal, with an
    /// optional unit (any case, a space allowed): `B`; `KB`, `MB`, `GB`, `TB`
    /// (powers of 1000); `KiB`, `MiB`, `GiB`, `TiB` (powers of 1024). `512MB`,
    /// `4GiB`, `1.5 GiB` and `1073741824` are budgets; `0`, `-1`, `4G` and `lots`
    /// are refused with a message saying what is valid.
    pub fn parse(s: &str) -> std::result::Result<Budget, String> {
        let t = s.trim();
        let split = t
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(t.len());
        let (number, unit) = t.split_at(split);
        let valid = "give a positive size in bytes, e.g. 1073741824, 512MB or 4GiB \
                     (KB, MB, GB, TB are powers of 1000; KiB, MiB, GiB, TiB of 1024)";
        // Cut as `io::cut` does (this module sits below `io`).
        let quoted = match s.char_indices().nth(60) {
            Some((i, _)) => format!("{}... ({} bytes in all)", &s[..i], s.len()),
            None => s.to_string(),
        };
        let value: f64 = number
            .parse()
            .map_err(|_| format!("`{quoted}` is not a size; {valid}"))?;
        let scale: u64 = match unit.trim().to_ascii_lowercase().as_str() {
            "" | "b" => 1,
            "kb" => 1_000,
            "mb" => 1_000_000,
            "gb" => 1_000_000_000,
            "tb" => 1_000_000_000_000,
            "kib" => 1 << 10,
            "mib" => 1 << 20,
            "gib" => 1 << 30,
            "tib" => 1 << 40,
            _ => return Err(format!("`{quoted}`: unknown size unit; {valid}")),
        };
        let too_large = || {
            format!(
                "`{quoted}` is more than the largest size, {} bytes (16 EiB); {valid}",
                u64::MAX
            )
        };
        // A whole number is taken exactly (u64::MAX is a size; f64 would round
        // it up past the largest).
        let bytes = match number.parse::<u64>() {
            Ok(whole) => whole.checked_mul(scale).ok_or_else(too_large)?,
            Err(_) if !number.contains('.') => return Err(too_large()),
            Err(_) => {
                let bytes = value * scale as f64;
                // Digits and dots only: never NaN. 2^64 as f64 is past u64::MAX.
                if bytes >= 18_446_744_073_709_551_616.0 {
                    return Err(too_large());
                }
                bytes as u64
            }
        };
        if bytes < 1 {
            return Err(format!(
                "`{quoted}` is no memory at all: every load and build would be refused; {valid}"
            ));
        }
        Ok(Budget(bytes))
    }
}

impl Default for Budget {
    fn default() -> Self {
        Budget::DEFAULT
    }
}

impl From<u64> for Budget {
    fn from(bytes: u64) -> Self {
        Budget(bytes)
    }
}

impl From<Budget> for u64 {
    fn from(b: Budget) -> u64 {
        b.0
    }
}

impl std::str::FromStr for Budget {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Budget, String> {
        Budget::parse(s)
    }
}

impl fmt::Display for Budget {
    /// The budget as people read it (`4 GiB`); see [`Size`].
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        Size(self.0).fmt(f)
    }
}

/// Refuses `needed` bytes for `what` when they exceed `budget` (a [`Budget`] or
/// bytes), before anything is allocated ([`Error::TooLarge`]).
/// Within the budget, `needed` is also held to what the machine can give
/// ([`machine_limit`], [`Error::MachineMemory`]): a budget larger than the
/// machine's memory ends in an error, not an aborted process.
pub fn check_budget(what: impl Into<String>, needed: u64, budget: impl Into<u64>) -> Result<()> {
    let budget = budget.into();
    if needed > budget {
        return Err(Error::TooLarge {
            what: what.into(),
            needed,
            budget,
        });
    }
    check_machine(what, needed)
}

/// `n` copies of `value`, or [`Error::Allocation`] naming `what` when the
/// system will not give the memory: for buffers whose size comes from the
/// input, so a failed allocation is an error, not an aborted process.
pub fn filled<T: Clone>(what: impl FnOnce() -> String, n: u64, value: T) -> Result<Vec<T>> {
    let refused = |what: String| Error::Allocation {
        what,
        needed: n.saturating_mul(std::mem::size_of::<T>() as u64),
    };
    let Ok(len) = usize::try_from(n) else {
        return Err(refused(what()));
    };
    let mut v = Vec::new();
    if v.try_reserve_exact(len).is_err() {
        return Err(refused(what()));
    }
    v.resize(len, value);
    Ok(v)
}

/// Refuses `needed` bytes for `what` when they are more than the machine can
/// give now ([`machine_limit`]); only large requests (over 64 MiB) read it.
pub fn check_machine(what: impl Into<String>, needed: u64) -> Result<()> {
    if needed <= 64 << 20 {
        return Ok(());
    }
    match machine_limit() {
        Some((available, limit)) if needed > available => Err(Error::MachineMemory {
            what: what.into(),
            needed,
            available,
            limit,
        }),
        _ => Ok(()),
    }
}

/// What this machine can give the process now, in bytes, and what sets it: the
/// least of the memory available plus free swap (`/proc/meminfo`), the
/// address-space limit less what the process maps (`ulimit -v`), and its
/// control group's memory limit less its use. `None` where none can be read
/// (other systems than Linux).
pub fn machine_limit() -> Option<(u64, &'static str)> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let limits = [
        read("/proc/meminfo")
            .and_then(|t| meminfo_available(&t))
            .map(|b| (b, "the memory available and free swap")),
        address_space_left().map(|left| (left, ADDRESS_SPACE)),
        read("/sys/fs/cgroup/memory.max")
            .and_then(|t| t.trim().parse::<u64>().ok())
            .zip(read("/sys/fs/cgroup/memory.current").and_then(|t| t.trim().parse::<u64>().ok()))
            .map(|(max, used)| (max.saturating_sub(used), "the control group's memory limit")),
    ];
    limits.into_iter().flatten().min_by_key(|l| l.0)
}

/// How [`machine_limit`] names the address-space limit.
pub const ADDRESS_SPACE: &str = "the process's address-space limit, ulimit -v";

/// What the process's address-space limit (`ulimit -v`) leaves it, in bytes;
/// `None` when there is no limit (or no `/proc` to read it from). Thread
/// stacks count against it when they are reserved, used or not.
pub fn address_space_left() -> Option<u64> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let limit = read("/proc/self/limits").and_then(|t| address_space_limit(&t))?;
    let used = read("/proc/self/status").and_then(|t| kib_field(&t, "VmSize:"))?;
    Some(limit.saturating_sub(used))
}

/// `MemAvailable` plus `SwapFree` of a `/proc/meminfo` text, in bytes.
fn meminfo_available(text: &str) -> Option<u64> {
    Some(kib_field(text, "MemAvailable:")? + kib_field(text, "SwapFree:").unwrap_or(0))
}

/// The value in bytes of the `name  123 kB` line of a `/proc` text.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The soft "Max address space" of a `/proc/self/limits` text, in bytes
/// (`None` when unlimited).
fn address_space_limit(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_buffer_the_system_will_not_give_is_an_error_naming_it() {
        let v = filled(|| "ten samples".into(), 10, 1.5f32).unwrap();
        assert_eq!(v, vec![1.5; 10]);
        // More than any address space (and more than usize on 32 bits): the
        // allocator refuses, and the error says what and how much.
        for n in [u64::MAX / 8, u64::MAX] {
            let e = filled(|| format!("the samples of {n} grid corners"), n, 0f32).unwrap_err();
            let text = e.to_string();
            assert!(matches!(e, Error::Allocation { .. }), "{e:?}");
            assert!(
                text.contains(&format!("the samples of {n} grid corners"))
                    && text.contains("the system would not allocate it"),
                "{text}"
            );
        }
    }

    #[test]
    fn sizes_parse_with_decimal_and_binary_units() {
        for (text, bytes) in [
            ("1073741824", 1 << 30),
            ("512MB", 512_000_000),
            ("512mb", 512_000_000),
            ("4GiB", 4 << 30),
            ("4 gib", 4 << 30),
            ("1.5GiB", 3 << 29),
            ("100 KiB", 102_400),
            ("2TB", 2_000_000_000_000),
            ("1B", 1),
            ("18446744073709551615", u64::MAX),
            ("16777215TiB", 16_777_215 << 40),
        ] {
            assert_eq!(Budget::parse(text), Ok(Budget::bytes(bytes)), "{text}");
            assert_eq!(text.parse::<Budget>(), Ok(Budget::bytes(bytes)), "{text}");
        }
    }

    #[test]
    fn the_machine_limit_reads_proc_texts() {
        let meminfo = "MemTotal:       24000000 kB\nMemFree:  100 kB\nMemAvailable:   20000000 kB\nSwapTotal: 0 kB\nSwapFree:        1000 kB\n";
        assert_eq!(meminfo_available(meminfo), Some(20_001_000 * 1024));
        assert_eq!(meminfo_available("MemTotal: 5 kB\n"), None);
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max stack size            8388608              unlimited            bytes\n\
                      Max address space         1073741824           unlimited            bytes\n";
        assert_eq!(address_space_limit(limits), Some(1 << 30));
        let unlimited =
            "Max address space         unlimited            unlimited            bytes\n";
        assert_eq!(address_space_limit(unlimited), None);
        assert_eq!(kib_field("VmSize:\t  2048 kB\n", "VmSize:"), Some(2 << 20));
        // Small requests never read the machine; huge ones on Linux are refused.
        assert!(check_machine("a small thing", 1 << 20).is_ok());
        if let Some((available, _)) = machine_limit() {
            let e = check_machine("a test", available.saturating_add(1 << 30)).unwrap_err();
            assert!(matches!(e, Error::MachineMemory { .. }), "{e:?}");
            assert!(
                e.to_string()
                    .contains("more than this machine can give now"),
                "{e}"
            );
        }
    }

    #[test]
    fn bad_sizes_say_what_is_valid() {
        for (text, says) in [
            ("0", "no memory at all"),
            ("0GiB", "no memory at all"),
            ("0.1", "no memory at all"),
            ("-1", "not a size"),
            ("", "not a size"),
            ("lots", "not a size"),
            ("4G", "unknown size unit"),
            ("4 GiB extra", "unknown size unit"),
            ("1.2.3MB", "not a size"),
            (
                "99999999999TiB",
                "more than the largest size, 18446744073709551615 bytes",
            ),
            ("18446744073709551616", "more than the largest size"),
            ("99999999999999999999999", "more than the largest size"),
            ("16777216TiB", "more than the largest size"),
            ("18446744073709551616.5", "more than the largest size"),
        ] {
            let e = Budget::parse(text).unwrap_err();
            assert!(e.contains(says), "{text}: {e}");
            assert!(e.contains("512MB or 4GiB"), "{text}: {e}");
        }
        let long = "9".repeat(10_000) + "x";
        assert!(Budget::parse(&long).unwrap_err().len() < 300);
    }

    #[test]
    fn budgets_print_as_people_read_them_and_shrink_as_they_are_spent() {
        assert_eq!(Budget::DEFAULT.to_string(), "4 GiB");
        assert_eq!(Budget::default(), Budget::bytes(DEFAULT_MEMORY_BUDGET));
        assert_eq!(Size(300).to_string(), "300 bytes");
        assert_eq!(Size(1536).to_string(), "1.50 KiB");
        assert_eq!(Size(512_000_000).to_string(), "488 MiB");
        assert_eq!(Budget::bytes(100).less(30), Budget::bytes(70));
        assert_eq!(Budget::bytes(100).less(300), Budget::bytes(0));
        assert!(Budget::bytes(100).check("x", 100).is_ok());
        let e = Budget::bytes(100).check("a test", 101).unwrap_err();
        assert!(
            matches!(
                e,
                Error::TooLarge {
                    needed: 101,
                    budget: 100,
                    ..
                }
            ),
            "{e:?}"
        );
        assert_eq!(u64::from(Budget::bytes(7)), 7);
    }
}
