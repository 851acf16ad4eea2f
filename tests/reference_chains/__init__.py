"""The hand-written skill chains of the first four tasks and their hidden-physics versions, kept as references: the
composed chains (phyplan_agents.phyplan.composer) must agree with them (tests/test_composer.py).

``REFERENCE[task]`` is ``(skills, rollout)`` with ``rollout(state, rows, skills, facts)`` -> final xy (N, 2).
"""
from . import bounce, bridge, launch, slide, varied

REFERENCE = {
    "launch": (launch.SKILLS, launch.rollout),
    "slide": (slide.SKILLS, slide.rollout),
    "bounce": (bounce.SKILLS, bounce.rollout),
    "bridge": (bridge.SKILLS, bridge.rollout),
    "launch-varied": (varied.LAUNCH_SKILLS, varied.launch),
    "slide-varied": (varied.SLIDE_SKILLS, varied.slide),
    "bounce-varied": (varied.BOUNCE_SKILLS, varied.bounce),
    "bridge-varied": (varied.BRIDGE_SKILLS, varied.bridge),
}
