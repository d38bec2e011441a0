"""Build mf_lateral_sets.csv: pure-lateral Magic Formula sets from public .tir files.

The coefficients below were transcribed by hand from the files named in each row (read from a
stored copy of the public repository at the commit given). Derived columns are evaluated at the
nominal load Fz = FNOMIN*LFZO (dfz = 0), camber 0, nominal pressure, no shifts. Run once; no
network access.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

HERE = Path(__file__).resolve().parent

BSD_CHRONO = "BSD-3-Clause (Project Chrono LICENSE)"
APACHE_TAD = "Apache-2.0 (TAD_Sim LICENSE, third-party exceptions)"

# family: "MF6" -> K_y = PKY1*Fz0'*sin(PKY4*atan(Fz/(PKY2*Fz0')))*LKY (FITTYP 61/62)
#         "MF5" -> same with PKY4 = 2 (PAC2002, MF5.2, MF-Tyre 5.0 'MF_05')
ROWS = [
    dict(
        source_repo="Tencent/TAD_Sim",
        path="simcore/catalogs/Dynamics/C100_Continental_225_50R18.tir",
        commit="2157c63e24ef83e28a3b457655ff48a03e8e2398",
        licence=APACHE_TAD,
        mf_version="MF-Tyre/MF-Swift 6.2 (FITTYP 62)",
        family="MF6",
        tyre="Continental UC6 225/50R18 (C100_Continental_225_50R18)",
        cls="car",
        measured="yes",
        FNOMIN=6762,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.586,
        PDY1=1.0057,
        PDY2=-0.36984,
        PEY1=-1.5894,
        PEY2=-2.0,
        PEY3=0.05788,
        PEY4=-5.946,
        PKY1=-19.81,
        PKY2=0.9467,
        PKY3=0.2125,
        PKY4=1.1738,
        duplicates="",
        note="MF-Tool 6.2 output (FT3, 2020), dry 16.7 m/s; same file as the longitudinal row",
    ),
    dict(
        source_repo="Tencent/TAD_Sim",
        path="simcore/catalogs/Dynamics/TASS_car205_60R15.tir",
        commit="2157c63e24ef83e28a3b457655ff48a03e8e2398",
        licence=APACHE_TAD,
        mf_version="MF-Tyre/MF-Swift 6.2 (FITTYP 62)",
        family="MF6",
        tyre="Delft-Tyre/TNO 205/60R15 (TNO_car205_60R15, MF-Tool 6.2, 2013)",
        cls="car",
        measured="yes",
        FNOMIN=4000,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.3332,
        PDY1=0.8784,
        PDY2=-0.06445,
        PEY1=-0.8227,
        PEY2=-0.6062,
        PEY3=0.09825,
        PEY4=-6.546,
        PKY1=-15.314,
        PKY2=1.7044,
        PKY3=0.36986,
        PKY4=1.9896,
        duplicates="",
        note="licensed copy of the TNO 205/60R15 set (longitudinal representative OpenTire/Sandbox MFeval_to_C++/TNO_car205_60R15.tir has no licence stated)",
    ),
    dict(
        source_repo="Tencent/TAD_Sim",
        path="simcore/catalogs/Dynamics/CS_car225_60R18.tir",
        commit="2157c63e24ef83e28a3b457655ff48a03e8e2398",
        licence=APACHE_TAD,
        mf_version="MF-Tyre/MF-Swift 6.1 header (TNO 2008), FITTYP 62",
        family="MF6",
        tyre="TNO/Pacejka-book 205/60R15 reference set, CarSim-modified dims (CS_car225_60R18)",
        cls="car",
        measured="yes",
        FNOMIN=4000,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.338,
        PDY1=0.8785,
        PDY2=-0.06451,
        PEY1=-0.804,
        PEY2=-0.6099,
        PEY3=0.09907,
        PEY4=-6.694,
        PKY1=-15.323,
        PKY2=1.7132,
        PKY3=0.3699,
        PKY4=2.0,
        duplicates="",
        note="file says it is TNO_car205_60R15.tir (MF 6.1, 2008) with dimensions modified by CarSim ('does not relate to any existing tire'); coefficients are the TNO fit (book reference tyre); licensed stand-in for OpenTire reference_tire_tvd3.tir",
    ),
    dict(
        source_repo="jcmadsen/PacTire_Matlab",
        path="pac2002_235_60R16.tir",
        commit="a49161e9150348e638c518335c3f36609e63a16b",
        licence="BSD-style (LICENSE, Justin Madsen 2014)",
        mf_version="PAC2002",
        family="MF5",
        tyre="pac2002_235_60R16 (Adams/Tire PAC2002 example, 235/60R16, 200 kPa)",
        cls="car",
        measured="unclear",
        FNOMIN=4850,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.3507,
        PDY1=1.0489,
        PDY2=-0.18033,
        PEY1=-0.0074722,
        PEY2=-0.0063208,
        PEY3=-9.9935,
        PEY4=-760.14,
        PKY1=-21.92,
        PKY2=2.0012,
        PKY3=-0.024778,
        PKY4=None,
        duplicates="projectchrono/chrono:data/vehicle/sedan/tire/Sedan_Pac02Tire.tir@420fac5336 (lateral block checked identical)",
        note="PEY3=-9.99 makes E sign-dependent: E(alpha>0)=PEY1*(1-PEY3)",
    ),
    dict(
        source_repo="mathworks/Vehicle-Dynamics-14DOF-Simscape-Multibody",
        path="Scripts_Data/KT_MF_Tool_245_60_R16.tir",
        commit="e07eab5ca3986f917e52f7f2c916ea2ae2a56d9e",
        licence="BSD-3-Clause-style (MathWorks LICENSE.md)",
        mf_version="MF-Tyre/MF-Swift 7.1 header, FITTYP 62",
        family="MF6",
        tyre="KT_MF_Tool_245_60_R16 (VPG Lab, RPSCOE, IIT Madras, for MathWorks)",
        cls="car",
        measured="generic",
        FNOMIN=5000,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.5015,
        PDY1=0.8401,
        PDY2=-0.0563,
        PEY1=-0.5276,
        PEY2=1.545,
        PEY3=0.0983,
        PEY4=-6.546,
        PKY1=-26.8535,
        PKY2=1.676,
        PKY3=0.3699,
        PKY4=1.4902,
        duplicates="",
        note="header: parameters not derived directly from experiments on a single tyre",
    ),
    dict(
        source_repo="projectchrono/chrono",
        path="data/vehicle/sedan/tire/Sedan_Pac02Tire.json",
        commit="531147c4cc24b1ce96b326307cd4967662062bea",
        licence=BSD_CHRONO,
        mf_version="PAC2002",
        family="MF5",
        tyre="Adams/Tire 2017.1 help PAC2002 example (chrono Sedan JSON)",
        cls="car",
        measured="generic",
        FNOMIN=4700,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.2676,
        PDY1=0.90031,
        PDY2=-0.16748,
        PEY1=-0.3442,
        PEY2=-0.10763,
        PEY3=0.11513,
        PEY4=-6.9663,
        PKY1=-25.714,
        PKY2=3.2658,
        PKY3=-0.0054467,
        PKY4=None,
        duplicates="",
        note="JSON, not .tir; stored version at 531147c4cc (longitudinal row cites 0830ec8d7e, same longitudinal set)",
    ),
    dict(
        source_repo="projectchrono/chrono",
        path="data/vehicle/generic/tire/MagicFormula61_Parameters.json",
        commit="c1ad8c2f0a0bd4caf5825f2b4b661044ea831e6c",
        licence=BSD_CHRONO,
        mf_version="MF6.1 (FITTYP 61)",
        family="MF6",
        tyre="MFeval example MagicFormula61_Parameters (255/55R20)",
        cls="suv",
        measured="unclear",
        FNOMIN=6752,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.4759,
        PDY1=1.0085,
        PDY2=-0.1323,
        PEY1=-0.34653,
        PEY2=-0.60297,
        PEY3=-0.084051,
        PEY4=-20.7741,
        PKY1=-28.3155,
        PKY2=3.313,
        PKY3=-0.21509,
        PKY4=2.7364,
        duplicates="projectchrono/chrono:data/vehicle/generic/tire/MagicFormula62_Parameters.json@721c137a7c (FITTYP 62, lateral identical)",
        note="licensed copy of the MFeval MF61 example (longitudinal representative girish-radhakrishnan-250894/slip_angle_control has no licence stated); provenance of the fit not stated",
    ),
    dict(
        source_repo="projectchrono/chrono",
        path="data/vehicle/uaz/tire/UAZBUS_Pac02Tire.tir",
        commit="420fac5336b827090c9704d3e491d8e6780ad470",
        licence=BSD_CHRONO,
        mf_version="PAC2002",
        family="MF5",
        tyre="chrono 'passenger car template' PAC2002 as UAZ 225/75R16",
        cls="suv",
        measured="unclear",
        FNOMIN=4000,
        LFZO=1.449275362,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.3223,
        PDY1=1.0141,
        PDY2=-0.12274,
        PEY1=-0.63772,
        PEY2=-0.050782,
        PEY3=-0.27333,
        PEY4=-8.3143,
        PKY1=-19.797,
        PKY2=1.7999,
        PKY3=0.0095418,
        PKY4=None,
        duplicates="projectchrono/chrono:data/vehicle/Nissan_Patrol/json/suv_Pac02Tire.tir@51ef84b2d3 (lateral identical)",
        note="LFZO=1.449: evaluated at dfz=0, i.e. Fz=FNOMIN*LFZO",
    ),
    dict(
        source_repo="projectchrono/chrono",
        path="data/vehicle/VW_microbus/json/mf_185_80R14.tir",
        commit="1d1265935e5e9b32e8bac05f6e7eb73bb2138cc9",
        licence=BSD_CHRONO,
        mf_version="PAC2002",
        family="MF5",
        tyre="185/80R14 (chrono VW microbus), 190 kPa",
        cls="light_truck",
        measured="unclear",
        FNOMIN=3800,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.4675,
        PDY1=0.94002,
        PDY2=-0.17669,
        PEY1=0.0040023,
        PEY2=0.00085719,
        PEY3=41.465,
        PEY4=665.25,
        PKY1=-12.536,
        PKY2=1.3856,
        PKY3=-0.93342,
        PKY4=None,
        duplicates="",
        note="PEY3=41.5: E(alpha>0)=PEY1*(1-PEY3)=-0.16, E(alpha<0)=+0.17",
    ),
    dict(
        source_repo="projectchrono/chrono",
        path="data/vehicle/generic/tire/MagicFormula52_Parameters.json",
        commit="c1ad8c2f0a0bd4caf5825f2b4b661044ea831e6c",
        licence=BSD_CHRONO,
        mf_version="MF5.2 (FITTYP 6 as written)",
        family="MF5",
        tyre="MFeval example MagicFormula52_Parameters (235/85R16)",
        cls="light_truck",
        measured="unclear",
        FNOMIN=9416.6,
        LFZO=1,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.889,
        PDY1=0.8271,
        PDY2=-0.2306,
        PEY1=0.4585,
        PEY2=-0.21823,
        PEY3=-0.3872,
        PEY4=3.96,
        PKY1=-29.1,
        PKY2=7.576,
        PKY3=0.944,
        PKY4=None,
        duplicates="",
        note="licensed copy of the MFeval MF52 example (OpenTire copy has no licence stated)",
    ),
]
for psi, fnom, note in [
    (40, 16929, ""),
    (60, 21674, "FNOMIN from the longitudinal table (same file, longitudinal block identical)"),
    (70, 24046, "FNOMIN from the longitudinal table (same file, longitudinal block identical)"),
    (95, 29912, ""),
]:
    coef = {
        40: (
            1.5328,
            -0.70977,
            0.14161,
            0.085482,
            -0.041758,
            0.83929,
            99.846,
            -14.584,
            2.1214,
            0.69802,
        ),
        60: (
            1.2742,
            -0.73151,
            0.10076,
            0.069355,
            -0.045834,
            0.23519,
            89.965,
            -12.265,
            2.3291,
            0.39846,
        ),
        70: (
            1.1449,
            -0.74238,
            0.080332,
            0.061291,
            -0.047872,
            -0.066861,
            85.025,
            -11.106,
            2.4329,
            0.24868,
        ),
        95: (
            0.54764,
            -1.1188,
            0.072812,
            0.056372,
            -0.065607,
            -0.28765,
            63.843,
            -9.5432,
            2.4559,
            0.62823,
        ),
    }[psi]
    ROWS.append(
        dict(
            source_repo="projectchrono/chrono",
            path=f"data/vehicle/feda/tires/335_65R22_5_G275MSA_{psi}psi.tir",
            commit="1b783125f3dce257581bb685eb0e817de49e7298",
            licence=BSD_CHRONO,
            mf_version="MF-Tyre 5.0 (MF_05, FITTYP 5)",
            family="MF5",
            tyre=f"Goodyear G275 MSA 335/65R22.5 @ {psi} psi",
            cls="truck",
            measured="yes",
            FNOMIN=fnom,
            LFZO=1,
            LCY=1,
            LMUY=1,
            LEY=1,
            LKY=1,
            PCY1=coef[0],
            PDY1=coef[1],
            PDY2=coef[2],
            PEY1=coef[3],
            PEY2=coef[4],
            PEY3=coef[5],
            PEY4=coef[6],
            PKY1=coef[7],
            PKY2=coef[8],
            PKY3=coef[9],
            PKY4=None,
            duplicates="",
            note=(
                "Goodyear FM_EXPORT_TIR, Calspan; PDY1<0 (sign convention): mu_peak=|PDY1|"
                + ("; " + note if note else "")
                + (
                    "; PCY1<1: no finite peak, peak = asymptotic D*sin(C*pi/2)"
                    if coef[0] <= 1
                    else ""
                )
            ),
        )
    )
ROWS.append(
    dict(
        source_repo="projectchrono/chrono",
        path="data/vehicle/hmmwv/tire/HMMWV_Pac02Tire.tir",
        commit="8583c88fd38349441b65d8ac214aadf88493e9a8",
        licence=BSD_CHRONO,
        mf_version="PAC2002",
        family="MF5",
        tyre="Adams/Car truck example 315/80R22.5 scaled to HMMWV 37x12.5R16.5",
        cls="truck",
        measured="generic",
        FNOMIN=35000,
        LFZO=0.580904846,
        LCY=1,
        LMUY=1,
        LEY=1,
        LKY=1,
        PCY1=1.5874,
        PDY1=0.73957,
        PDY2=-0.075004,
        PEY1=0.37562,
        PEY2=-0.069325,
        PEY3=0.29168,
        PEY4=11.559,
        PKY1=-10.289,
        PKY2=3.3343,
        PKY3=-0.25732,
        PKY4=None,
        duplicates="",
        note="stored version 8583c88fd3 (longitudinal row cites 420fac5336, same longitudinal set); LFZO=0.581: evaluated at Fz=FNOMIN*LFZO",
    )
)


def ky_over_fz(r, dfz=0.0):
    """|K_y|/F_z at F_z = Fz0'(1+dfz), camber 0, nominal pressure."""
    p4 = 2.0 if r["family"] == "MF5" else r["PKY4"]
    x = 1.0 + dfz
    return abs(r["PKY1"] * r["LKY"] * math.sin(p4 * math.atan(x / r["PKY2"]))) / x


def shape_ratios(C, E, fractions=(0.3, 0.5)):
    """Secant/tangent slope where the pure MF force is `fraction` of its peak (rising branch)."""

    def f(x):
        return math.sin(C * math.atan(x - E * (x - math.atan(x))))

    xs = np.linspace(1e-6, 200.0, 400001)
    ys = np.sin(C * np.arctan(xs - E * (xs - np.arctan(xs))))
    i = int(np.argmax(ys))
    peak = ys[i] if C > 1 else math.sin(C * math.pi / 2)
    out = []
    for q in fractions:
        target = q * peak
        j = int(np.argmax(ys >= target))
        x = brentq(lambda t, target=target: f(t) - target, xs[max(j - 1, 0)] if j else 1e-9, xs[j])
        out.append(round(f(x) / (x * C), 4))
    return out


def main():
    cols = [
        "source_repo",
        "path",
        "commit",
        "licence",
        "mf_version",
        "tyre",
        "class",
        "measured",
        "FNOMIN",
        "fz_eval_n",
        "PCY1",
        "PDY1",
        "PDY2",
        "PEY1",
        "PEY2",
        "PEY3",
        "PEY4",
        "PKY1",
        "PKY2",
        "PKY3",
        "PKY4",
        "LCY",
        "LMUY",
        "LEY",
        "LKY",
        "LFZO",
        "C",
        "mu_peak",
        "E",
        "E_pos",
        "E_neg",
        "Ky_over_Fz",
        "ky_load_sens",
        "ratio_30pct",
        "ratio_50pct",
        "duplicates",
        "note",
    ]
    out = []
    for r in ROWS:
        C = r["PCY1"] * r["LCY"]
        E = r["PEY1"] * r["LEY"]
        E_pos = E * (1.0 - r["PEY3"])
        E_neg = E * (1.0 + r["PEY3"])
        h = 1e-4
        sens = (math.log(ky_over_fz(r, h)) - math.log(ky_over_fz(r, -h))) / (2 * h)
        r30, r50 = shape_ratios(C, min(E_pos, 1.0))
        out.append(
            {
                **{k: r.get(k) for k in cols if k in r},
                "class": r["cls"],
                "PKY4": r["PKY4"] if r["PKY4"] is not None else "",
                "fz_eval_n": round(r["FNOMIN"] * r["LFZO"], 1),
                "C": round(C, 5),
                "mu_peak": round(abs(r["PDY1"]) * r["LMUY"], 5),
                "E": round(E, 5),
                "E_pos": round(E_pos, 5),
                "E_neg": round(E_neg, 5),
                "Ky_over_Fz": round(ky_over_fz(r), 4),
                "ky_load_sens": round(sens, 4),
                "ratio_30pct": r30,
                "ratio_50pct": r50,
            }
        )
    with open(HERE / "mf_lateral_sets.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols)
        w.writeheader()
        w.writerows(out)


if __name__ == "__main__":
    main()
