//! The GPU's clocks beside its rows: the adapter's clocks recorded in the row where the
//! driver exposes them. NVIDIA's driver exposes them through `nvidia-smi`: on an NVIDIA
//! adapter the run starts it once, in loop mode (`--query-gpu=pci.device_id,clocks.sm,
//! clocks.mem --loop-ms=100`), and a thread keeps its samples of the adapter's SM and memory clocks;
//! a GPU row takes those sampled while its rows were timed (between the probes before and
//! after them). Elsewhere, or where the tool is absent or fails, nothing is sampled and the
//! columns stay empty. `TRACE_BENCH_NVIDIA_SMI` names another program (tests give a fake one).

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// PCI vendor id of NVIDIA adapters (`wgpu::AdapterInfo::vendor`).
pub const NVIDIA: u32 = 0x10de;

/// Milliseconds between samples.
pub const EVERY_MS: u32 = 100;

/// One sample: when it was read, the SM and memory clocks, MHz.
#[derive(Clone, Copy, Debug)]
struct Sample {
    at: Instant,
    sm: f64,
    mem: f64,
}

/// What a row records: the least and most SM clock sampled in its window and the mean memory
/// clock, MHz.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window {
    /// The least SM clock sampled, MHz.
    pub sm_min: f64,
    /// The most SM clock sampled, MHz.
    pub sm_max: f64,
    /// The mean memory clock, MHz.
    pub mem: f64,
}

/// The sampler: the tool's process (killed when dropped) and the samples its reader keeps.
pub struct Clocks {
    child: Child,
    samples: Arc<Mutex<Vec<Sample>>>,
}

impl Clocks {
    /// Start sampling adapter `device` (its PCI device id) of `vendor`: `None` but for NVIDIA
    /// adapters where the tool starts.
    pub fn start(vendor: u32, device: u32) -> Option<Clocks> {
        if vendor != NVIDIA {
            return None;
        }
        let program =
            std::env::var("TRACE_BENCH_NVIDIA_SMI").unwrap_or_else(|_| "nvidia-smi".into());
        let mut child = Command::new(program)
            .args([
                "--query-gpu=pci.device_id,clocks.sm,clocks.mem",
                "--format=csv,noheader,nounits",
                &format!("--loop-ms={EVERY_MS}"),
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .stdin(Stdio::null())
            .spawn()
            .ok()?;
        let out = child.stdout.take()?;
        let samples = Arc::new(Mutex::new(Vec::new()));
        let keep = samples.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines() {
                let Ok(line) = line else { break };
                if let Some((sm, mem)) = parse(&line, device) {
                    let s = Sample {
                        at: Instant::now(),
                        sm,
                        mem,
                    };
                    keep.lock().unwrap_or_else(|p| p.into_inner()).push(s);
                }
            }
        });
        Some(Clocks { child, samples })
    }

    /// The clocks sampled between `from` and `to` (with the last sample before `from`, the
    /// clocks in force when the window opened); `None` without samples.
    pub fn window(&self, from: Instant, to: Instant) -> Option<Window> {
        let samples = self.samples.lock().unwrap_or_else(|p| p.into_inner());
        let first = samples.partition_point(|s| s.at < from).saturating_sub(1);
        let inside: Vec<&Sample> = samples[first..].iter().filter(|s| s.at <= to).collect();
        if inside.is_empty() {
            return None;
        }
        let sm = inside.iter().map(|s| s.sm);
        Some(Window {
            sm_min: sm.clone().fold(f64::INFINITY, f64::min),
            sm_max: sm.fold(f64::NEG_INFINITY, f64::max),
            mem: inside.iter().map(|s| s.mem).sum::<f64>() / inside.len() as f64,
        })
    }
}

impl Drop for Clocks {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A line `0x233510DE, 1980, 2619` (PCI device and vendor id, SM and memory clock, MHz) of the
/// adapter with PCI device id `device`: its clocks; `None` for another GPU or another line.
fn parse(line: &str, device: u32) -> Option<(f64, f64)> {
    let mut f = line.split(',').map(str::trim);
    let id = f.next()?;
    let id = u32::from_str_radix(id.strip_prefix("0x").or(id.strip_prefix("0X"))?, 16).ok()?;
    if id >> 16 != device {
        return None;
    }
    let sm = f.next()?.parse().ok()?;
    let mem = f.next()?.parse().ok()?;
    Some((sm, mem))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_of_the_adapter_are_read() {
        assert_eq!(
            parse("0x233510DE, 1980, 2619", 0x2335),
            Some((1980.0, 2619.0))
        );
        assert_eq!(parse("0x233510DE, 1980, 2619", 0x2330), None);
        assert_eq!(parse("0x233510DE, [N/A], 2619", 0x2335), None);
        assert_eq!(parse("pci.device_id, clocks.sm", 0x2335), None);
    }

    #[test]
    fn other_vendors_are_not_sampled() {
        assert!(Clocks::start(0x1002, 0x73bf).is_none());
    }

    /// A fake `nvidia-smi` printing two GPUs' lines: the window holds the adapter's.
    #[cfg(unix)]
    #[test]
    fn a_window_holds_the_samples_of_its_time() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("tb-clocks-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fake = dir.join("nvidia-smi");
        std::fs::write(
            &fake,
            "#!/bin/sh\nwhile true; do echo '0x233510DE, 1980, 2619'; echo '0x111110DE, 500, 100'; echo '0x233510DE, 1755, 2619'; sleep 0.05; done\n",
        )
        .unwrap();
        std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
        std::env::set_var("TRACE_BENCH_NVIDIA_SMI", &fake);
        let c = Clocks::start(NVIDIA, 0x2335).expect("the fake tool starts");
        let from = Instant::now();
        std::thread::sleep(std::time::Duration::from_millis(400));
        let w = c.window(from, Instant::now()).expect("samples");
        assert_eq!(
            w,
            Window {
                sm_min: 1755.0,
                sm_max: 1980.0,
                mem: 2619.0
            }
        );
        // A window that closed before the tool started has none.
        assert!(c
            .window(
                from - std::time::Duration::from_secs(9),
                from - std::time::Duration::from_secs(8)
            )
            .is_none());
        drop(c);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
