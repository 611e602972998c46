//! The engineering units of every human-readable output (printed lines, `report.md`,
//! plots): gyro bias in °/h, accelerometer bias in mg, misalignment and flexure in
//! arcmin, lengths in m, delays in ms. Files for machines stay in SI.

/// Standard gravity (m/s²), the `g` of mg.
pub const G0: f64 = 9.806_65;

/// A displayed unit: its name and the factor from SI.
#[derive(Clone, Copy, Debug)]
pub struct Unit {
    /// Its name as printed.
    pub name: &'static str,
    /// Multiply an SI value by this.
    pub scale: f64,
}

/// Gyro bias: rad/s → °/h.
pub const GYRO_BIAS: Unit = Unit {
    name: "°/h",
    scale: 180.0 / std::f64::consts::PI * 3600.0,
};
/// Accelerometer bias: m/s² → mg.
pub const ACCEL_BIAS: Unit = Unit {
    name: "mg",
    scale: 1000.0 / G0,
};
/// Angles (misalignment, flexure): rad → arcmin.
pub const ANGLE: Unit = Unit {
    name: "arcmin",
    scale: 180.0 / std::f64::consts::PI * 60.0,
};
/// Gyro angle random walk: rad/√s → °/√h.
pub const ARW: Unit = Unit {
    name: "°/√h",
    scale: 180.0 / std::f64::consts::PI * 60.0,
};
/// Accelerometer velocity random walk: m/s/√s → m/s/√h.
pub const VRW: Unit = Unit {
    name: "m/s/√h",
    scale: 60.0,
};

/// The display unit of an augmented effect's SI unit (`Effect::unit`): scale factors in
/// ppm, angles in arcmin, delays in ms, g-sensitivity in °/h/g, lengths as they are.
pub fn of_effect_unit(si: &'static str) -> Unit {
    match si {
        "1" => Unit {
            name: "ppm",
            scale: 1e6,
        },
        "s" => Unit {
            name: "ms",
            scale: 1000.0,
        },
        "rad" => ANGLE,
        "rad/s/(m/s^2)" => Unit {
            name: "°/h/g",
            scale: GYRO_BIAS.scale * G0,
        },
        other => Unit {
            name: other,
            scale: 1.0,
        },
    }
}

/// An SI value `v` shown in unit `u` with 3 significant digits and the unit's name.
pub fn show(v: f64, u: Unit) -> String {
    format!("{} {}", sig3(v * u.scale), u.name)
}

/// SI values shown in unit `u` with 3 significant digits, comma separated (no unit name).
pub fn list(v: &[f64], u: Unit) -> String {
    v.iter()
        .map(|x| sig3(x * u.scale))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Angular rates of motion (not biases): rad/s → °/s.
pub const RATE: Unit = Unit {
    name: "°/s",
    scale: 180.0 / std::f64::consts::PI,
};

/// `v` with 3 significant digits, plain for ordinary magnitudes.
pub fn sig3(v: f64) -> String {
    crate::verdict::g3(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales() {
        assert!((GYRO_BIAS.scale * 4.848_136_811e-6 - 1.0).abs() < 1e-9);
        assert!((ACCEL_BIAS.scale * G0 - 1000.0).abs() < 1e-9);
        assert!((ANGLE.scale * (1.0f64 / 60.0).to_radians() - 1.0).abs() < 1e-12);
        assert_eq!(of_effect_unit("s").name, "ms");
    }
}
