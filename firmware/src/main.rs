//! The CS-MAEKF AHRS as firmware for a Cortex-M4F: `no_std`, no heap, no operating
//! system, in single precision on the FPU (feature `f64`: double precision, in software).
//! It runs the filter over the sensor sequence compiled into it
//! (`data/flight.bin`, 60 s of the simulated loitering flight at 100 Hz as 16-bit counts),
//! prints the attitude every 100 samples by semihosting, then the stack's high-water mark,
//! and exits. `firmware/check` runs it under QEMU and compares it with the host.
#![no_std]
#![no_main]

use core::ptr::{addr_of, addr_of_mut};

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
#[cfg(not(feature = "baseline"))]
use models::ahrs::onboard::cs_maekf_model;
use models::ahrs::Recording;
#[cfg(not(feature = "baseline"))]
use models::ahrs::{Ahrs, AhrsMeasurement};

/// The filter's scalar.
#[cfg(not(any(feature = "f64", feature = "baseline")))]
type S = f32;
/// The filter's scalar.
#[cfg(all(feature = "f64", not(feature = "baseline")))]
type S = f64;

/// The recorded sensor sequence.
static FLIGHT: &[u8] = include_bytes!("../data/flight.bin");

/// The word the free RAM is painted with before the run; the stack's high-water mark is
/// where the painting stops being intact.
const PAINT: u32 = 0xDEAD_BEEF;

extern "C" {
    /// Start of the free RAM above `.data` and `.bss` (cortex-m-rt).
    static mut __sheap: u32;
    /// Top of the stack (cortex-m-rt: the end of RAM).
    static _stack_start: u32;
}

#[entry]
fn main() -> ! {
    // Paint the free RAM up to a little below the current stack pointer.
    let bottom = addr_of_mut!(__sheap);
    let top = addr_of!(_stack_start) as usize;
    let sp = cortex_m::register::msp::read() as usize;
    let mut p = bottom;
    while (p as usize) < sp - 256 {
        // SAFETY: between the end of .bss and the live stack: RAM nothing else uses.
        unsafe {
            p.write_volatile(PAINT);
            p = p.add(1);
        }
    }

    let code = match run() {
        Ok(()) => debug::EXIT_SUCCESS,
        Err(msg) => {
            hprintln!("error: {}", msg);
            debug::EXIT_FAILURE
        }
    };

    // The lowest painted word that changed is the deepest the stack went.
    let mut p = bottom as *const u32;
    // SAFETY: the same painted region, read back.
    while (p as usize) < sp && unsafe { p.read_volatile() } == PAINT {
        p = unsafe { p.add(1) };
    }
    hprintln!("stack high-water {} bytes", top - p as usize);
    debug::exit(code);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Feature `baseline`: the same program without the filter (the samples are only summed),
/// so that the filter's own flash and stack are the differences between the two builds.
#[cfg(feature = "baseline")]
fn run() -> Result<(), &'static str> {
    let rec = Recording::parse(FLIGHT).map_err(|_| "the compiled-in recording is unreadable")?;
    let mut sum = nalgebra::Vector3::<f64>::zeros();
    for k in 0..rec.len() {
        let [g, a, m] = rec.sample::<f64>(k).ok_or("sample past the end")?;
        sum += g + a + m;
        if (k + 1) % 100 == 0 || k + 1 == rec.len() {
            hprintln!("att {} {:.15e} {:.15e} {:.15e}", k + 1, sum.x, sum.y, sum.z);
        }
    }
    hprintln!("done {} samples", rec.len());
    Ok(())
}

#[cfg(not(feature = "baseline"))]
fn run() -> Result<(), &'static str> {
    let rec = Recording::parse(FLIGHT).map_err(|_| "the compiled-in recording is unreadable")?;
    let model = cs_maekf_model(rec.gyro_noise, rec.rate);
    let lit = |v: f64| v as S;
    let meas = AhrsMeasurement { g_n: rec.g_n.map(lit), m_n: rec.m_n.map(lit) };
    let mut ahrs =
        Ahrs::<S>::new(model, meas, rec.att0.cast::<S>(), rec.rate).map_err(|_| "filter start")?;
    for k in 0..rec.len() {
        let [g, a, m] = rec.sample::<S>(k).ok_or("sample past the end")?;
        ahrs.step(&g, &a, &m).map_err(|_| "filter step failed")?;
        if (k + 1) % 100 == 0 || k + 1 == rec.len() {
            let (r, p, y) = ahrs.state().att.euler();
            hprintln!("att {} {:.15e} {:.15e} {:.15e}", k + 1, r, p, y);
        }
    }
    hprintln!("done {} samples", rec.len());
    Ok(())
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("panic: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
