"""Small MJCF pieces that every phyplan scene (tasks and skill-data scenes) is composed from.

All physical constants of the suite live here, once, so that the skill scenes that generate training data and the
task scenes an agent is scored in share the same objects. Units: metres, kilograms, seconds, radians.

Collision groups (MuJoCo ``contype``/``conaffinity`` bits):
    bit 1 (value 1): the static world (ground, tables, pedestal, goal box, wedge, bridge)
    bit 2 (value 2): the pendulum bob
    moving objects (ball, puck) carry both bits, so they collide with the world and with the bob, while the bob
    passes through the world (it never touches the table or the pedestal) and the Panda collides with nothing.
"""
from __future__ import annotations

import math

import numpy as np
from dm_control import mjcf

# --- simulation ----------------------------------------------------------------------------------------------------
TIMESTEP = 0.001          # s; docs/physics.md: the puck case fails at 0.002, and dt 0.001 allows stiff elastic contacts
GRAVITY = 9.81            # m/s^2
MAX_SIM_TIME = 4.0        # s; the episode cap of the reference code

# --- pendulum (reference: length 0.3 m, 10 g rod, 0.03 m cube bob of 0.5 kg) ------------------------------------------
PENDULUM_LENGTH = 0.3     # pivot to bob centre
BOB_HALF = 0.015          # half edge of the cube bob
BOB_MASS = 0.5
ROD_RADIUS = 0.005
ROD_MASS = 0.01
HIT_GAP = 0.0005          # gap between the bob face (at the bottom of its arc) and the object at rest

# --- moving objects ------------------------------------------------------------------------------------------------------
BALL_RADIUS = 0.02
BALL_MASS = 0.1           # tuned: with the nearly inelastic bob contact, launch ranges cover the 0.3-0.6 m goals
PUCK_RADIUS = 0.02
PUCK_HALF_HEIGHT = 0.005
PUCK_MASS = 0.05          # tuned: the puck leaves at ~1.03-1.06x the bob speed, so slides span ~0.45-1.5 m at mu 0.2
OBJECT_FRICTION = 0.2     # sliding friction of ball and puck (MuJoCo takes the max of the two geoms)

# --- static scenery -------------------------------------------------------------------------------------------------------
PEDESTAL_HALF = 0.025     # 0.05 x 0.05 column
PEDESTAL_HEIGHT = 0.313
TABLE_HEIGHT = 0.313
TABLE_FRICTION = 0.2      # the unknown mu that the sliding PINN learns
GOAL_HALF = 0.05          # the goal box is 0.1 x 0.1
GOAL_WALL_HEIGHT = 0.02
GOAL_WALL_THICK = 0.005
GOAL_FLOOR_THICK = 0.004

# Elastic contacts need MuJoCo's negative solref form (stiffness, damping): docs/physics.md.
ELASTIC_SOLREF = "-200000 -15"   # restitution ~0.95 at dt 0.001

OBJECT_RGBA = (0.15, 0.75, 0.2, 1)
GOAL_RGBA = (0.85, 0.1, 0.1, 1)
TOOL_RGBA = (0.2, 0.35, 0.85, 1)
WOOD_RGBA = (0.6, 0.45, 0.3, 1)

WORLD = dict(contype=1, conaffinity=1)
OBJECT = dict(contype=3, conaffinity=3)
BOB = dict(contype=2, conaffinity=2)
GHOST = dict(contype=0, conaffinity=0)


def bob_speed(theta: float | np.ndarray) -> float | np.ndarray:
    """Ideal speed of the bob at the bottom of its arc when released from rest at ``theta`` (energy conservation)."""
    return np.sqrt(2 * GRAVITY * PENDULUM_LENGTH * (1 - np.cos(theta)))


def yaw_quat(yaw: float) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation by ``yaw`` about the world z axis."""
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


# ------------------------------------------------------------------------------------------------------------------------
def arena(name: str = "phyplan") -> mjcf.RootElement:
    """An empty world: options, cheap headless rendering settings, ground, lights and the two cameras."""
    root = mjcf.RootElement(model=name)
    root.option.timestep = TIMESTEP
    root.option.gravity = (0, 0, -GRAVITY)
    # Elliptic friction cones: pyramidal cones bend a sliding puck towards the contact frame's diagonals (measured:
    # a puck hit along 0.3 rad slid along 0.51 rad); elliptic ones keep the direction within 0.004 rad and the
    # sliding distance within 0.98-1.04 x v^2/(2 mu g) (docs/tasks.md, "Physical parameters").
    root.option.cone = "elliptic"
    root.option.integrator = "Euler"
    root.visual.quality.shadowsize = 0   # shadows dominate software rendering cost
    root.visual.quality.offsamples = 0
    root.visual.headlight.ambient = (0.45, 0.45, 0.45)
    root.visual.headlight.diffuse = (0.5, 0.5, 0.5)
    root.visual.map.znear = 0.01
    getattr(root.visual, "global").offwidth = 640
    getattr(root.visual, "global").offheight = 640
    root.asset.add("texture", name="grid", type="2d", builtin="checker", rgb1=(0.82, 0.84, 0.86),
                   rgb2=(0.74, 0.76, 0.78), width=256, height=256)
    root.asset.add("material", name="grid", texture="grid", texrepeat=(8, 8), reflectance=0)
    root.worldbody.add("geom", name="ground", type="plane", size=(6, 6, 0.1), material="grid",
                       friction=(0.8, 0.005, 0.0001), **WORLD)
    root.worldbody.add("light", name="top", pos=(0.5, 0.5, 3.0), dir=(0, 0, -1), castshadow=False,
                       diffuse=(0.4, 0.4, 0.4))
    return root


def add_camera(root: mjcf.RootElement, name: str, pos, lookat, fovy: float = 45) -> None:
    """A fixed camera at ``pos`` looking at ``lookat`` (world frame)."""
    pos = np.asarray(pos, dtype=float)
    fwd = np.asarray(lookat, dtype=float) - pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    if np.linalg.norm(right) < 1e-6:
        right = np.array([1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    root.worldbody.add("camera", name=name, pos=pos, xyaxes=np.concatenate([right, up]), fovy=fovy)


def add_pendulum(root: mjcf.RootElement, name: str = "pendulum", bob_mass: float = BOB_MASS) -> mjcf.Element:
    """A pendulum rig: a static body (placed and yawed per attempt) holding a hinge about its local y axis.

    Positive hinge angle lifts the bob towards local -x; released, it swings through the bottom of its arc moving
    towards local +x, where the object sits. The visual frame (posts and bar) collides with nothing.
    """
    rig = root.worldbody.add("body", name=name, pos=(0, 0, 1))
    rig.add("geom", name=f"{name}_bar", type="capsule", fromto=(0, -0.06, 0, 0, 0.06, 0), size=(0.006,),
            rgba=(0.3, 0.3, 0.3, 1), mass=0, **GHOST)
    arm = rig.add("body", name=f"{name}_arm")
    arm.add("joint", name=f"{name}_hinge", type="hinge", axis=(0, 1, 0), damping=0, armature=0)
    arm.add("geom", name=f"{name}_rod", type="capsule", fromto=(0, 0, 0, 0, 0, -(PENDULUM_LENGTH - BOB_HALF)),
            size=(ROD_RADIUS,), mass=ROD_MASS, rgba=(0.35, 0.35, 0.35, 1), **GHOST)
    arm.add("geom", name=f"{name}_bob", type="box", pos=(0, 0, -PENDULUM_LENGTH), size=(BOB_HALF,) * 3,
            mass=bob_mass, rgba=TOOL_RGBA, priority=2, condim=1, friction=(0, 0, 0), **BOB)
    return rig


def add_ball(root: mjcf.RootElement, name: str = "ball", mass: float = BALL_MASS) -> mjcf.Element:
    body = root.worldbody.add("body", name=name, pos=(0, 0, 1))
    body.add("freejoint", name=f"{name}_free")
    body.add("geom", name=f"{name}_geom", type="sphere", size=(BALL_RADIUS,), mass=mass, rgba=OBJECT_RGBA,
             friction=(OBJECT_FRICTION, 0.005, 0.0001), **OBJECT)
    return body


def add_puck(root: mjcf.RootElement, name: str = "puck", mass: float = PUCK_MASS) -> mjcf.Element:
    body = root.worldbody.add("body", name=name, pos=(0, 0, 1))
    body.add("freejoint", name=f"{name}_free")
    body.add("geom", name=f"{name}_geom", type="cylinder", size=(PUCK_RADIUS, PUCK_HALF_HEIGHT), mass=mass,
             rgba=OBJECT_RGBA, friction=(OBJECT_FRICTION, 0.005, 0.0001), **OBJECT)
    return body


def add_pedestal(root: mjcf.RootElement, pos=(0, 0), name: str = "pedestal") -> mjcf.Element:
    """A frictionless column (docs/physics.md: with friction the ball leaves spinning and lands up to 2.5x farther)."""
    return root.worldbody.add("geom", name=name, type="box", pos=(pos[0], pos[1], PEDESTAL_HEIGHT / 2),
                              size=(PEDESTAL_HALF, PEDESTAL_HALF, PEDESTAL_HEIGHT / 2), rgba=WOOD_RGBA,
                              priority=1, condim=1, friction=(0, 0, 0), **WORLD)


def add_table(root: mjcf.RootElement, xmin: float, xmax: float, ymin: float, ymax: float,
              height: float = TABLE_HEIGHT, name: str = "table", friction: float = TABLE_FRICTION) -> mjcf.Element:
    """A rectangular table top with friction ``friction`` (legs are visual only)."""
    body = root.worldbody.add("body", name=name, pos=((xmin + xmax) / 2, (ymin + ymax) / 2, 0))
    hx, hy = (xmax - xmin) / 2, (ymax - ymin) / 2
    body.add("geom", name=f"{name}_top", type="box", pos=(0, 0, height - 0.01), size=(hx, hy, 0.01),
             rgba=(0.75, 0.72, 0.68, 1), friction=(friction, 0.005, 0.0001), **WORLD)
    for sx in (-1, 1):
        for sy in (-1, 1):
            body.add("geom", type="box", pos=(sx * (hx - 0.03), sy * (hy - 0.03), (height - 0.02) / 2),
                     size=(0.02, 0.02, (height - 0.02) / 2), rgba=(0.4, 0.33, 0.28, 1), **GHOST)
    return body


def add_round_table(root: mjcf.RootElement, radius: float, height: float = TABLE_HEIGHT, name: str = "table",
                    friction: float = TABLE_FRICTION) -> mjcf.Element:
    body = root.worldbody.add("body", name=name, pos=(0, 0, 0))
    body.add("geom", name=f"{name}_top", type="cylinder", pos=(0, 0, height - 0.01), size=(radius, 0.01),
             rgba=(0.75, 0.72, 0.68, 1), friction=(friction, 0.005, 0.0001), **WORLD)
    body.add("geom", type="cylinder", pos=(0, 0, (height - 0.02) / 2), size=(0.03, (height - 0.02) / 2),
             rgba=(0.4, 0.33, 0.28, 1), **GHOST)
    return body


def add_goal_box(root: mjcf.RootElement, name: str = "goal", walls: bool = True, base_z: float = 0.0) -> mjcf.Element:
    """The 0.1 x 0.1 goal: a box with low walls on the ground (``walls=False``: a flat marker, e.g. on a table)."""
    body = root.worldbody.add("body", name=name, pos=(0, 0, base_z), mocap=False)
    body.add("geom", name=f"{name}_floor", type="box", pos=(0, 0, GOAL_FLOOR_THICK / 2),
             size=(GOAL_HALF, GOAL_HALF, GOAL_FLOOR_THICK / 2), rgba=GOAL_RGBA,
             **(WORLD if walls else GHOST))
    if walls:
        h = GOAL_WALL_HEIGHT / 2
        t = GOAL_WALL_THICK / 2
        for i, (px, py, sx, sy) in enumerate([(GOAL_HALF - t, 0, t, GOAL_HALF), (-GOAL_HALF + t, 0, t, GOAL_HALF),
                                              (0, GOAL_HALF - t, GOAL_HALF, t), (0, -GOAL_HALF + t, GOAL_HALF, t)]):
            body.add("geom", name=f"{name}_wall{i}", type="box", pos=(px, py, h), size=(sx, sy, h),
                     rgba=(0.7, 0.1, 0.1, 1), **WORLD)
    return body


# --- Bridge (PhyPlan/Bridge-v0, -v1) ----------------------------------------------------------------------------------
BRIDGE_TABLE_RADIUS = 0.25   # round table of the reference task
BRIDGE_LENGTH = 0.75         # plank length from the table edge (reference 0.25; tuned, see tasks/bridge.py)
BRIDGE_WIDTH = 0.125         # plank width (reference)
BRIDGE_THICK = 0.05          # plank thickness (reference)
BRIDGE_DROP = 0.002          # plank top below the table top; a flush plank knocks the puck back (tasks/bridge.py)


def bridge_overlap(table_radius: float = BRIDGE_TABLE_RADIUS, width: float = BRIDGE_WIDTH) -> float:
    """How far the plank reaches under the round table's rim so that no gap opens at its corners.

    A straight plank end meets a round rim only on its centreline; ``R - sqrt(R^2 - (w/2)^2)`` (7.9 mm for the
    reference sizes) is the largest gap across its width.
    """
    return table_radius - math.sqrt(table_radius ** 2 - (width / 2) ** 2)


def add_bridge(root: mjcf.RootElement, table_radius: float = BRIDGE_TABLE_RADIUS, height: float = TABLE_HEIGHT,
               length: float = BRIDGE_LENGTH, width: float = BRIDGE_WIDTH, thick: float = BRIDGE_THICK,
               drop: float = BRIDGE_DROP, name: str = "bridge", friction: float = TABLE_FRICTION) -> mjcf.Element:
    """A bridge plank on two stands, in a static body at the table centre that is yawed to place the bridge.

    Along the body's local +x the plank runs from the table rim (``table_radius``) to ``table_radius + length``
    (it also reaches :func:`bridge_overlap` under the rim), ``width`` wide and ``thick`` thick, its top ``drop``
    below ``height``. Its top has the table's friction, so the puck decelerates on it exactly as on the table.
    The stands are visual only (they touch nothing).
    """
    body = root.worldbody.add("body", name=name, pos=(0, 0, 0))
    start = table_radius - bridge_overlap(table_radius, width)
    end = table_radius + length
    top = height - drop
    body.add("geom", name=f"{name}_plank", type="box", pos=((start + end) / 2, 0, top - thick / 2),
             size=((end - start) / 2, width / 2, thick / 2), rgba=TOOL_RGBA,
             friction=(friction, 0.005, 0.0001), **WORLD)
    leg_h = (top - thick) / 2
    for i, x in enumerate((table_radius + 0.03, end - 0.03)):
        for sy in (-1, 1):
            body.add("geom", name=f"{name}_stand{i}{'ab'[sy > 0]}", type="box",
                     pos=(x, sy * (width / 2 - 0.012), leg_h), size=(0.01, 0.01, leg_h),
                     rgba=(0.3, 0.3, 0.45, 1), **GHOST)
    return body


# --- Bounce: the 45 degree wedge on its round stand -------------------------------------------------------------------
WEDGE_HALF = 0.15                 # half edge of the square base: the reference wedge's 0.3 x 0.3 footprint
WEDGE_ANGLE = math.pi / 4         # incline angle (reference: 45 degrees); the ridge is 0.3 m above the base
WEDGE_STAND_HEIGHT = 0.15         # tuned: a round stand lifts the impact point to WEDGE_IMPACT_Z, so that drop
                                  # heights 0.5-1.5 m give landing ranges ~0.44-1.07 m, covering the reference goals
                                  # (0.42-1.06 m from the wedge); on the ground the range would end at ~0.82 m
WEDGE_STAND_RADIUS = 0.22         # just covers the yawed wedge's base (corner radius 0.212)
# Ball-centre height when it meets the incline straight above the wedge's yaw axis: stand + mid-incline height +
# BALL_RADIUS / cos(angle) (the centre of a sphere touching a 45 degree plane is r*sqrt(2) above it).
WEDGE_IMPACT_Z = (WEDGE_STAND_HEIGHT + WEDGE_HALF * math.tan(WEDGE_ANGLE)
                  + BALL_RADIUS / math.cos(WEDGE_ANGLE))


def add_wedge(root: mjcf.RootElement, name: str = "wedge", stand_height: float = WEDGE_STAND_HEIGHT) -> mjcf.Element:
    """A 45 degree wedge (triangular prism mesh) on a round stand, as one static body yawed about its origin.

    The body origin is on the ground; its vertical axis passes through the middle of the incline, so a ball dropped
    on that axis meets the incline at the same point (ball centre at ``WEDGE_IMPACT_Z``) for every yaw. At yaw 0 the
    incline falls towards +x: its outward normal is (1, 0, 1)/sqrt(2) and a dropped ball leaves along +x.

    Only the incline's contact with the ball is elastic: the prism has ``priority=1``, so its ``condim=1``
    (frictionless), zero friction and ``ELASTIC_SOLREF`` (restitution ~0.95, docs/physics.md) govern that contact,
    while the ground and the stand keep MuJoCo's damped defaults.
    """
    h = WEDGE_HALF
    top = 2 * h * math.tan(WEDGE_ANGLE)
    # base square at z = 0, ridge edge at x = -h, z = top: the incline runs from the ridge down to x = +h
    vertices = (-h, -h, 0, h, -h, 0, h, h, 0, -h, h, 0, -h, -h, top, -h, h, top)
    root.asset.add("mesh", name=f"{name}_prism", vertex=vertices)
    body = root.worldbody.add("body", name=name, pos=(0, 0, 0))
    if stand_height > 0:          # stand_height 0: the wedge stands on the ground (LaunchBounce)
        body.add("geom", name=f"{name}_stand", type="cylinder", pos=(0, 0, stand_height / 2),
                 size=(WEDGE_STAND_RADIUS, stand_height / 2), rgba=(0.45, 0.45, 0.5, 1), **WORLD)
    body.add("geom", name=f"{name}_incline", type="mesh", mesh=f"{name}_prism", pos=(0, 0, stand_height),
             rgba=TOOL_RGBA, priority=1, condim=1, friction=(0, 0, 0),
             solref=[float(v) for v in ELASTIC_SOLREF.split()], **WORLD)
    return body


# --- Paddles: a shelf and N tilted paddles --------------------------------------------------------------------------
PADDLE_HALF = 0.25                # half edge of the 0.5 m square paddle (the original code's paddles)
PADDLE_THICK = 0.02               # paddle board thickness (m): thick enough that the ball never tunnels at 0.5 ms
PADDLE_TILT = math.pi / 4         # each paddle's tilt from horizontal (alternately +-45 degrees)
PADDLE_RESTITUTION = 0.0          # the paddles keep none of the ball's normal speed (the original's 0.1 hopped the ball
                                  # over most of a paddle, and a second touch at its lower edge made 8% of landings
                                  # jump under 1e-4 action changes)
PADDLE_SOLREF = (0.004, 2.0)      # an overdamped contact (time constant 4 ms, damping ratio 2): the ball leaves a
                                  # paddle with < 0.01 m/s of its 1.6-4.9 m/s normal speed, where the critically
                                  # damped negative solref (-2e5, -2 sqrt(2e5)) still returned 12-14% of it
PADDLE_STIFFNESS = 200000.0       # K of the paddle contact's negative solref (the wedge's)


def add_paddle(root: mjcf.RootElement, name: str, solref, half: float = PADDLE_HALF) -> mjcf.Element:
    """A square paddle board of half edge ``half`` (default 0.25: 0.5 m square) as one static body (posed by the
    task): its top face is the incline, with the wedge's contact settings (``priority=1``, ``condim=1``:
    frictionless) and the negative ``solref`` given. The body origin is the centre of the top face; unrotated the
    board is level."""
    body = root.worldbody.add("body", name=name, pos=(0, 0, 0))
    body.add("geom", name=f"{name}_board", type="box", pos=(0, 0, -PADDLE_THICK / 2),
             size=(half, half, PADDLE_THICK / 2), rgba=TOOL_RGBA, priority=1, condim=1,
             friction=(0, 0, 0), solref=[float(v) for v in solref], **WORLD)
    return body
