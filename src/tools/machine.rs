//! The machine a benchmark ran on. Every `stokes bench` report names it, because peer
//! ratios (packets against single rays, stokes against Mitsuba) change from one CPU to
//! another, and a figure without its CPU cannot be compared with another.

use serde::Serialize;
use std::fmt;

/// What a figure depends on besides the code: the CPU and what Embree can use on it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Machine {
    /// The CPU's model name (`/proc/cpuinfo`), or `unknown`.
    pub cpu: String,
    /// The x86 family and model numbers. A virtual machine's model name can be as vague
    /// as "AMD EPYC"; family 25, model 1 says Zen 3.
    pub family: Option<u32>,
    /// See [`Machine::family`].
    pub model: Option<u32>,
    /// Logical CPUs this process may run on.
    pub logical_cpus: usize,
    /// The widest of Embree's kernel sets ([`crate::accel::ISAS`]) this CPU can run, which
    /// Embree picks unless `STOKES_EMBREE_CONFIG` caps it.
    pub embree_isa: &'static str,
    /// `STOKES_EMBREE_CONFIG`, when set.
    pub embree_config: Option<String>,
}

/// The CPU's model name, family and model from the text of `/proc/cpuinfo` (its first
/// processor's entries; every processor of a machine has the same).
pub fn parse_cpuinfo(text: &str) -> (Option<String>, Option<u32>, Option<u32>) {
    let mut name = None;
    let (mut family, mut model) = (None, None);
    for line in text.lines() {
        let Some((key, value)) = line.split_once(':') else {
            continue;
        };
        let value = value.trim();
        match key.trim() {
            "model name" if name.is_none() => name = Some(value.to_string()),
            "cpu family" if family.is_none() => family = value.parse().ok(),
            "model" if model.is_none() => model = value.parse().ok(),
            _ => {}
        }
    }
    (name, family, model)
}

impl Machine {
    /// This machine. What cannot be read is left unknown rather than failing the
    /// benchmark.
    pub fn detect() -> Machine {
        let text = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let (name, family, model) = parse_cpuinfo(&text);
        let embree_isa = crate::accel::ISAS
            .iter()
            .rev()
            .map(|&(isa, _)| isa)
            .find(|isa| crate::accel::cpu_has_isa(isa))
            .unwrap_or("unknown");
        Machine {
            cpu: name.unwrap_or_else(|| "unknown".to_string()),
            family,
            model,
            logical_cpus: std::thread::available_parallelism().map_or(0, |n| n.get()),
            embree_isa,
            embree_config: std::env::var(crate::accel::CONFIG_VARIABLE).ok(),
        }
    }
}

/// One line for the head of a table: `CPU: AMD EPYC (family 25, model 1), 2 logical
/// CPUs, Embree kernels the CPU can run: up to avx2`.
impl fmt::Display for Machine {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "CPU: {}", self.cpu)?;
        if let (Some(family), Some(model)) = (self.family, self.model) {
            write!(f, " (family {family}, model {model})")?;
        }
        write!(
            f,
            ", {} logical CPUs, Embree kernels the CPU can run: up to {}",
            self.logical_cpus, self.embree_isa
        )?;
        if let Some(config) = &self.embree_config {
            write!(f, " ({}={config})", crate::accel::CONFIG_VARIABLE)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ZEN3: &str = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 25\n\
        model\t\t: 1\nmodel name\t: AMD EPYC\nflags\t\t: fpu sse2\n\nprocessor\t: 1\n\
        cpu family\t: 25\nmodel\t\t: 1\nmodel name\t: AMD EPYC\n";

    #[test]
    fn reads_name_family_and_model_not_confusing_model_with_model_name() {
        assert_eq!(
            parse_cpuinfo(ZEN3),
            (Some("AMD EPYC".to_string()), Some(25), Some(1))
        );
    }

    #[test]
    fn missing_or_garbled_entries_stay_unknown() {
        assert_eq!(parse_cpuinfo(""), (None, None, None));
        let odd = "model name\t: Some CPU @ 2.60GHz\ncpu family\t: six\n";
        assert_eq!(
            parse_cpuinfo(odd),
            (Some("Some CPU @ 2.60GHz".to_string()), None, None)
        );
    }

    #[test]
    fn one_line_names_the_cpu_and_embree_kernels() {
        let m = Machine {
            cpu: "AMD EPYC".into(),
            family: Some(25),
            model: Some(1),
            logical_cpus: 2,
            embree_isa: "avx2",
            embree_config: Some("max_isa=sse2".into()),
        };
        assert_eq!(
            m.to_string(),
            "CPU: AMD EPYC (family 25, model 1), 2 logical CPUs, Embree kernels the CPU can \
             run: up to avx2 (STOKES_EMBREE_CONFIG=max_isa=sse2)"
        );
    }

    #[test]
    fn this_machine_has_at_least_sse2() {
        let m = Machine::detect();
        assert!(m.logical_cpus >= 1);
        #[cfg(target_arch = "x86_64")]
        assert_ne!(m.embree_isa, "unknown");
    }
}
