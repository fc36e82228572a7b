#pragma once
/// @file
/// @brief The one internal unit system of brainshift: millimetre, kilogram, second.
///
/// Derived units: force in millinewton (mN = kg·mm/s²), stress and moduli in kilopascal
/// (kPa = mN/mm²), density in kg/mm³, acceleration in mm/s². Brain moduli (1.5–10 kPa) are
/// therefore numbers near 1. Every length in every interface is in mm, in world (scanner, RAS)
/// coordinates; conversions happen only at I/O boundaries.

namespace brainshift::units {

inline constexpr double mm = 1.0;                ///< length
inline constexpr double m = 1000.0 * mm;         ///< metre, in mm
inline constexpr double kg = 1.0;                ///< mass
inline constexpr double s = 1.0;                 ///< time
inline constexpr double mN = kg * mm / (s * s);  ///< force: millinewton
inline constexpr double N = 1000.0 * mN;         ///< newton, in mN
inline constexpr double kPa = mN / (mm * mm);    ///< stress: kilopascal (mN/mm²)
inline constexpr double Pa = 1e-3 * kPa;         ///< pascal, in kPa

/// Standard gravity, mm/s².
inline constexpr double standard_gravity = 9810.0 * mm / (s * s);
/// Density of brain tissue (≈ water), kg/mm³ (1040 kg/m³).
inline constexpr double brain_density = 1040.0 * kg / (m * m * m);
/// Density of cerebrospinal fluid, kg/mm³ (1007 kg/m³).
inline constexpr double csf_density = 1007.0 * kg / (m * m * m);

/// Default materials of seed 002 (Morin et al. 2017).
inline constexpr double brain_youngs_modulus = 1.5 * kPa;
inline constexpr double tumour_youngs_modulus = 10.0 * kPa;
inline constexpr double default_poisson_ratio = 0.45;

}  // namespace brainshift::units
