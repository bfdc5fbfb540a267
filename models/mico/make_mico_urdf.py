"""Generate ``mico.urdf`` (our own Kinova MICO model) from Kinova's classic DH parameters.

Run ``python models/mico/make_mico_urdf.py`` after changing anything below; the URDF is committed
next to this script so that nothing has to be generated at run time.

Kinematics (Kinova, "DH Parameters of Mico" v1.0.1, classic DH, FACTS.md section 7)::

    T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i),   X_base_ee = T_1 T_2 ... T_6

The URDF joint angles ARE the DH angles theta_i. Link ``mico_link_i`` is DH frame i-1 rotated by
theta_i about z_{i-1}; the constant part ``Tz(d_i) Tx(a_i) Rx(alpha_i)`` of row i is the origin of
joint i+1 (and, for row 6, the origin of the fixed joint to ``mico_end_effector``), so the
end-effector frame is exactly DH frame 6 (z out of the hand, fingers opening along y).

Joint limits are Kinova's actuator limits converted to DH angles. Kinova's actuator angles q_k
relate to the DH angles by theta_2 = q_2 - 90 deg and theta_3 = q_3 + 90 deg (q_2 = q_3 = 180 deg is
the straight-up "candle" pose; theta_2 = 90 deg points the upper arm straight up and theta_3 = 270 deg
stretches the elbow), so the actuator ranges q_2 in [47, 313] deg and q_3 in [19, 341] deg become
theta_2 in [-43, 223] deg and theta_3 in [109, 431] deg. Joints 1, 4, 5, 6 are continuous on the real
arm; the model limits them to +/- 2 pi.

Masses add up to 4.6 kg (Kinova's figure for the arm with its gripper); each link's inertia is the
composite inertia of the primitive shapes that draw it, so it is physically valid by construction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# --- Kinova MICO DH parameters (metres, radians) -------------------------------------------------
D1, D2, D3, D4, D5, D6 = 0.2755, 0.2900, 0.1233, 0.0741, 0.0741, 0.1600
E2 = 0.0070
AA = math.radians(30.0)
_K = math.sin(AA) / math.sin(2.0 * AA)
D4B = D3 + _K * D4
D5B = _K * (D4 + D5)
D6B = _K * D5 + D6

# (d, a, alpha) of each row; theta offsets are all zero.
DH_ROWS = [
    (D1, 0.0, math.pi / 2),
    (0.0, D2, math.pi),
    (-E2, 0.0, math.pi / 2),
    (-D4B, 0.0, 2 * AA),
    (-D5B, 0.0, 2 * AA),
    (-D6B, 0.0, math.pi),
]

TWO_PI = 2.0 * math.pi
JOINT_LIMITS = [
    (-TWO_PI, TWO_PI),
    (math.radians(47.0 - 90.0), math.radians(313.0 - 90.0)),
    (math.radians(19.0 + 90.0), math.radians(341.0 + 90.0)),
    (-TWO_PI, TWO_PI),
    (-TWO_PI, TWO_PI),
    (-TWO_PI, TWO_PI),
]
BIG_SPEED = math.radians(36.0)  # rad/s, joints 1-3 (KA-75+ actuators)
WRIST_SPEED = math.radians(48.0)  # rad/s, joints 4-6 (KA-58 actuators)
JOINT_SPEEDS = [BIG_SPEED] * 3 + [WRIST_SPEED] * 3
JOINT_EFFORTS = [30.5] * 3 + [6.8] * 3  # N m, peak torques of KA-75+ / KA-58
# Reflected rotor inertia (kg m^2) of the geared actuators; makes the discrete plant better damped.
ROTOR_INERTIA = [1e-5] * 3 + [5e-6] * 3
GEAR_RATIO = [100.0] * 6

FINGER_TRAVEL = 0.06  # m per finger: opening 0 .. 0.12 m
FINGER_SPEED = 0.10  # m/s
FINGER_EFFORT = 20.0  # N

DARK = "0.20 0.20 0.22 1"
RING = "0.62 0.64 0.68 1"
FINGER = "0.12 0.12 0.12 1"


# --- small geometry helpers ---------------------------------------------------------------------
def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rpy_of(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (R = Rz(y) Ry(p) Rx(r)) of a rotation matrix."""
    pitch = math.asin(-max(-1.0, min(1.0, R[2, 0])))
    if abs(math.cos(pitch)) > 1e-9:
        roll = math.atan2(R[2, 1], R[2, 2])
        yaw = math.atan2(R[1, 0], R[0, 0])
    else:  # gimbal lock: put everything into roll
        roll = math.atan2(-R[1, 2], R[1, 1])
        yaw = 0.0
    return roll, pitch, yaw


def axis_rotation(direction: np.ndarray) -> np.ndarray:
    """A rotation taking +z to ``direction`` (unit)."""
    z = np.asarray(direction, float) / np.linalg.norm(direction)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


@dataclass
class Piece:
    """A primitive (cylinder or box) in a link frame, with the mass it carries."""

    kind: str  # "cylinder" | "box"
    dims: tuple[float, ...]  # (radius, length) or (sx, sy, sz)
    center: np.ndarray
    R: np.ndarray
    mass: float
    rgba: str
    collide: bool = False

    def inertia_at_center(self) -> np.ndarray:
        m = self.mass
        if self.kind == "cylinder":
            r, L = self.dims
            ixx = m * (3 * r * r + L * L) / 12.0
            local = np.diag([ixx, ixx, m * r * r / 2.0])
        else:
            sx, sy, sz = self.dims
            local = np.diag(
                [
                    m * (sy * sy + sz * sz) / 12.0,
                    m * (sx * sx + sz * sz) / 12.0,
                    m * (sx * sx + sy * sy) / 12.0,
                ]
            )
        return self.R @ local @ self.R.T


def segment(p0, p1, radius: float, mass: float, rgba: str = DARK, collide: bool = True) -> Piece:
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    return Piece(
        "cylinder", (radius, float(np.linalg.norm(d))), (p0 + p1) / 2, axis_rotation(d), mass, rgba, collide
    )


def ring(center, axis, radius: float, length: float, mass: float) -> Piece:
    return Piece("cylinder", (radius, length), np.asarray(center, float), axis_rotation(axis), mass, RING)


def box(center, size, mass: float, rgba: str = DARK, R=None, collide: bool = False) -> Piece:
    return Piece(
        "box", tuple(size), np.asarray(center, float), np.eye(3) if R is None else R, mass, rgba, collide
    )


def next_axis(alpha: float) -> np.ndarray:
    """Direction of the next joint's axis in the current link frame: Rx(alpha) e_z."""
    return rot_x(alpha) @ np.array([0.0, 0.0, 1.0])


# --- link geometry (each link frame is DH frame i-1 rotated by theta_i) ---------------------------
BASE_TOP = 0.14


def link_pieces() -> dict[str, list[Piece]]:
    (d1, _, al1), (_, a2, al2), (d3, _, al3), (d4, _, al4), (d5, _, al5), (d6, _, _) = DH_ROWS
    # The hand in link-6 coordinates: EE frame = Tz(d6) Rx(pi); R_6E maps EE coords to link-6 coords.
    R_6E = rot_x(math.pi)
    p_6E = np.array([0.0, 0.0, d6])

    def in6(p_E) -> np.ndarray:
        return p_6E + R_6E @ np.asarray(p_E, float)

    pieces = {
        "mico_link_base": [
            Piece("cylinder", (0.075, 0.012), np.array([0, 0, 0.006]), np.eye(3), 0.20, RING),
            segment([0, 0, 0.012], [0, 0, BASE_TOP], 0.05, 0.40, collide=False),
        ],
        "mico_link_1": [
            segment([0, 0, BASE_TOP], [0, 0, d1], 0.045, 0.45),
            ring([0, 0, d1], next_axis(al1), 0.05, 0.10, 0.30),
        ],
        "mico_link_2": [
            segment([0, 0, 0], [a2, 0, 0], 0.04, 0.69),
            ring([a2, 0, 0], next_axis(al2), 0.045, 0.09, 0.30),
        ],
        # Elbow offset and the forearm tube (it does not turn with joint 4) up to actuator 4 at D3.
        "mico_link_3": [
            segment([0, 0, 0], [0, 0, d3], 0.04, 0.05, collide=False),
            segment([0, 0, d3], [0, 0, d3] + D3 * -next_axis(al3), 0.035, 0.50),
        ],
        # The last bit of the forearm to the 4-5 axis intersection, and the first wrist joint.
        "mico_link_4": [
            segment([0, 0, -D3], [0, 0, d4], 0.035, 0.15),
            ring([0, 0, d4], next_axis(al4), 0.038, 0.075, 0.30),
        ],
        "mico_link_5": [
            segment([0, 0, 0], [0, 0, d5], 0.03, 0.20),
            ring([0, 0, d5], next_axis(al5), 0.035, 0.07, 0.20),
        ],
        "mico_link_6": [
            segment(in6([0, 0, d6]), in6([0, 0, -0.075]), 0.035, 0.45),
            box(in6([0, 0, -0.07]), (0.05, 0.15, 0.012), 0.25, RING, R=R_6E, collide=True),
        ],
        # Finger frames coincide with the EE frame at zero opening; the left finger slides along
        # +y_E, the right one along -y_E, inner faces at y = +/- q.
        "mico_link_finger_left": [
            box([0, 0.006, -0.025], (0.022, 0.012, 0.09), 0.08, FINGER, collide=True),
        ],
        "mico_link_finger_right": [
            box([0, -0.006, -0.025], (0.022, 0.012, 0.09), 0.08, FINGER, collide=True),
        ],
    }
    return pieces


# --- URDF writer ---------------------------------------------------------------------------------
def fmt(x: float) -> str:
    if abs(x) < 1e-14:  # round-off from the rotations above
        x = 0.0
    s = f"{x:.10g}"
    return "0" if s in ("-0", "0") else s


def vec(v) -> str:
    return " ".join(fmt(float(x)) for x in v)


def inertial_xml(pieces: list[Piece]) -> str:
    m = sum(p.mass for p in pieces)
    com = sum(p.mass * p.center for p in pieces) / m
    inertia = np.zeros((3, 3))
    for p in pieces:
        r = p.center - com
        inertia += p.inertia_at_center() + p.mass * (np.dot(r, r) * np.eye(3) - np.outer(r, r))
    ixx, iyy, izz = inertia[0, 0], inertia[1, 1], inertia[2, 2]
    ixy, ixz, iyz = inertia[0, 1], inertia[0, 2], inertia[1, 2]
    return (
        f'    <inertial>\n      <origin xyz="{vec(com)}" rpy="0 0 0"/>\n      <mass value="{fmt(m)}"/>\n'
        f'      <inertia ixx="{fmt(ixx)}" ixy="{fmt(ixy)}" ixz="{fmt(ixz)}" iyy="{fmt(iyy)}" '
        f'iyz="{fmt(iyz)}" izz="{fmt(izz)}"/>\n    </inertial>\n'
    )


def geometry_xml(p: Piece) -> str:
    if p.kind == "cylinder":
        return f'<cylinder radius="{fmt(p.dims[0])}" length="{fmt(p.dims[1])}"/>'
    return f'<box size="{vec(p.dims)}"/>'


def link_xml(name: str, pieces: list[Piece]) -> str:
    out = [f'  <link name="{name}">\n', inertial_xml(pieces)]
    for k, p in enumerate(pieces):
        origin = f'<origin xyz="{vec(p.center)}" rpy="{vec(rpy_of(p.R))}"/>'
        out.append(
            f'    <visual name="{name}_visual_{k}">\n      {origin}\n'
            f"      <geometry>{geometry_xml(p)}</geometry>\n"
            f'      <material><color rgba="{p.rgba}"/></material>\n    </visual>\n'
        )
        if p.collide:
            out.append(
                f'    <collision name="{name}_collision_{k}">\n      {origin}\n'
                f"      <geometry>{geometry_xml(p)}</geometry>\n    </collision>\n"
            )
    out.append("  </link>\n")
    return "".join(out)


def joint_xml(
    name: str,
    kind: str,
    parent: str,
    child: str,
    xyz,
    rpy,
    axis=None,
    limits: tuple[float, float, float, float] | None = None,
) -> str:
    s = f'  <joint name="{name}" type="{kind}">\n    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
    s += f'    <origin xyz="{vec(xyz)}" rpy="{vec(rpy)}"/>\n'
    if axis is not None:
        s += f'    <axis xyz="{vec(axis)}"/>\n'
    if limits is not None:
        lo, hi, effort, speed = limits
        s += f'    <limit lower="{fmt(lo)}" upper="{fmt(hi)}" '
        s += f'effort="{fmt(effort)}" velocity="{fmt(speed)}"/>\n'
        s += '    <dynamics damping="0.0" friction="0.0"/>\n'
    s += "  </joint>\n"
    return s


def transmission_xml(joint: str, rotor_inertia: float | None = None, gear_ratio: float | None = None) -> str:
    extra = ""
    if rotor_inertia is not None:
        extra += f'      <drake:rotor_inertia value="{fmt(rotor_inertia)}"/>\n'
    if gear_ratio is not None:
        extra += f'      <drake:gear_ratio value="{fmt(gear_ratio)}"/>\n'
    return (
        f'  <transmission name="{joint}_transmission">\n'
        "    <type>transmission_interface/SimpleTransmission</type>\n"
        f'    <joint name="{joint}">\n'
        "      <hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>\n"
        "    </joint>\n"
        f'    <actuator name="{joint}_actuator">\n{extra}'
        "      <mechanicalReduction>1</mechanicalReduction>\n"
        "    </actuator>\n"
        "  </transmission>\n"
    )


def make_urdf() -> str:
    pieces = link_pieces()
    parts = [
        '<?xml version="1.0"?>\n',
        "<!-- GENERATED by models/mico/make_mico_urdf.py from Kinova's MICO DH parameters; "
        "do not edit. -->\n",
        "<!-- Joint angles are the classic-DH angles; mico_end_effector is DH frame 6. -->\n",
        '<robot name="mico" xmlns:drake="http://drake.mit.edu">\n',
    ]
    for name, ps in pieces.items():
        parts.append(link_xml(name, ps))
    parts.append('  <link name="mico_end_effector"/>\n')

    links = ["mico_link_base"] + [f"mico_link_{i}" for i in range(1, 7)]
    for i in range(1, 7):
        if i == 1:
            xyz, rpy = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        else:
            d, a, alpha = DH_ROWS[i - 2]
            xyz, rpy = (a, 0.0, d), (alpha, 0.0, 0.0)
        lo, hi = JOINT_LIMITS[i - 1]
        parts.append(
            joint_xml(
                f"mico_joint_{i}",
                "revolute",
                links[i - 1],
                links[i],
                xyz,
                rpy,
                (0, 0, 1),
                (lo, hi, JOINT_EFFORTS[i - 1], JOINT_SPEEDS[i - 1]),
            )
        )
    d6, a6, alpha6 = DH_ROWS[5]
    parts.append(
        joint_xml(
            "mico_joint_end_effector",
            "fixed",
            "mico_link_6",
            "mico_end_effector",
            (a6, 0, d6),
            (alpha6, 0, 0),
        )
    )
    for side, sign in (("left", 1.0), ("right", -1.0)):
        parts.append(
            joint_xml(
                f"mico_finger_joint_{side}",
                "prismatic",
                "mico_link_6",
                f"mico_link_finger_{side}",
                (a6, 0, d6),
                (alpha6, 0, 0),
                (0, sign, 0),
                (0.0, FINGER_TRAVEL, FINGER_EFFORT, FINGER_SPEED),
            )
        )
    for i in range(1, 7):
        parts.append(transmission_xml(f"mico_joint_{i}", ROTOR_INERTIA[i - 1], GEAR_RATIO[i - 1]))
    for side in ("left", "right"):
        parts.append(transmission_xml(f"mico_finger_joint_{side}"))
    parts.append("</robot>\n")
    return "".join(parts)


def main() -> None:
    out = Path(__file__).resolve().with_name("mico.urdf")
    out.write_text(make_urdf())
    total = sum(p.mass for ps in link_pieces().values() for p in ps)
    print(f"wrote {out} (total mass {total:.3f} kg)")


if __name__ == "__main__":
    main()
