//! The navigation result written as an RTKLIB solution file.

use super::*;

/// Writes the header of a `.pos` file in RTKLIB's layout (LLH in degrees, GPST as week
/// and seconds of week, σ and covariances, and the velocity with its σ when `velocity`).
pub fn write_header<W: Write>(w: &mut W, program: &str, velocity: bool) -> std::io::Result<()> {
    write_header_mode(
        w,
        program,
        "INS/GNSS (the filter's state at the GNSS antenna's IMU origin)",
        velocity,
    )
}

/// [`write_header`] with the `pos mode` line's text given.
pub fn write_header_mode<W: Write>(
    w: &mut W,
    program: &str,
    mode: &str,
    velocity: bool,
) -> std::io::Result<()> {
    writeln!(w, "% program   : {program}")?;
    writeln!(w, "% pos mode  : {mode}")?;
    writeln!(
        w,
        "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)"
    )?;
    write!(
        w,
        "%  GPST   {:>16} {:>16} {:>12} {:>3} {:>3} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>6} {:>6}",
        "latitude(deg)",
        "longitude(deg)",
        "height(m)",
        "Q",
        "ns",
        "sdn(m)",
        "sde(m)",
        "sdu(m)",
        "sdne(m)",
        "sdeu(m)",
        "sdun(m)",
        "age(s)",
        "ratio"
    )?;
    if velocity {
        write!(
            w,
            " {:>11} {:>11} {:>11} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
            "vn(m/s)", "ve(m/s)", "vu(m/s)", "sdvn", "sdve", "sdvu", "sdvne", "sdveu", "sdvun"
        )?;
    }
    writeln!(w)
}

/// The signed square root RTKLIB writes for a covariance.
pub(super) fn sqvar(c: f64) -> f64 {
    if c < 0.0 {
        -(-c).sqrt()
    } else {
        c.sqrt()
    }
}

/// Appends one epoch to `out`: GPS `week` and seconds of week `t`, the position, its NED
/// covariance, and the velocity (NED) with its covariance. `Q` is written as 1 when the
/// epoch is a GNSS fix's and 5 otherwise (an inertial solution, no GNSS that epoch); `ns`
/// as 0. The numbers are written by [`push_exact`](crate::fixed::push_exact): the bytes
/// `format!` wrote before (tested), faster.
#[allow(clippy::too_many_arguments)]
pub fn push_epoch(
    out: &mut Vec<u8>,
    week: f64,
    t: f64,
    pos: &GeoPos,
    pos_cov: &Matrix3<f64>,
    vel: Option<(&Vector3<f64>, &Matrix3<f64>)>,
    q: u8,
) {
    push_epoch_ns(out, week, t, pos, pos_cov, vel, q, 0);
}

/// [`push_epoch`] with the number of satellites `ns` written.
#[allow(clippy::too_many_arguments)]
pub fn push_epoch_ns(
    out: &mut Vec<u8>,
    week: f64,
    t: f64,
    pos: &GeoPos,
    pos_cov: &Matrix3<f64>,
    vel: Option<(&Vector3<f64>, &Matrix3<f64>)>,
    q: u8,
    ns: usize,
) {
    // each value after a space, right-aligned in its width (wider values overflow it)
    let field = |out: &mut Vec<u8>, v: f64, width: usize, decimals: usize| {
        out.push(b' ');
        crate::fixed::push_exact(out, v, width, decimals);
    };
    let d = 180.0 / core::f64::consts::PI;
    // NED → NEU
    let f = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
    let c = f * pos_cov * f;
    let _ = write!(out, "{:4}", week as i64);
    field(out, t, 11, 4);
    field(out, pos.lat * d, 16, 11);
    field(out, pos.lon * d, 16, 11);
    field(out, pos.h, 12, 6);
    let _ = write!(out, " {:3} {:3}", q, ns);
    let sd = |c: &Matrix3<f64>| {
        [
            c[(0, 0)].sqrt(),
            c[(1, 1)].sqrt(),
            c[(2, 2)].sqrt(),
            sqvar(c[(0, 1)]),
            sqvar(c[(1, 2)]),
            sqvar(c[(2, 0)]),
        ]
    };
    for v in sd(&c) {
        field(out, v, 9, 6);
    }
    field(out, 0.0, 6, 2);
    field(out, 0.0, 6, 1);
    if let Some((v, vc)) = vel {
        for x in [v.x, v.y, -v.z] {
            field(out, x, 11, 6);
        }
        for x in sd(&(f * vc * f)) {
            field(out, x, 9, 6);
        }
    }
    out.push(b'\n');
}

/// ECEF of a geodetic position (for writers and tests).
pub fn to_ecef(p: &GeoPos) -> Vector3<f64> {
    geodetic_to_ecef(p.lat, p.lon, p.h)
}
