import mujoco
import pytest

from sim.grasping import (GRASP_CLASSES, GRASP_MAPPINGS, GRASP_NAMES, GRASP_OBJECTS, ROBOT_GRASPS,
    VOLAR_GRASPS, check_grasp_class, robot_grasp_for)


def test_every_class_has_a_name_an_object_and_a_robot_grasp():
    assert set(GRASP_NAMES) == set(GRASP_OBJECTS) == set(GRASP_CLASSES)
    assert VOLAR_GRASPS <= set(GRASP_CLASSES)
    for tables in GRASP_MAPPINGS.values():
        for hand, table in tables.items():
            assert set(table) == set(GRASP_CLASSES)
            assert set(table.values()) <= set(ROBOT_GRASPS[hand])


def test_mappings_follow_the_papers():
    # MAP 2009 Fig. 2: (a,b)->Wrap, (c,d)->Two-finger Thumb, (e,f)->Precision Disc for the Barrett hand;
    # (a,c,d)->Power, (b)->Wrap, (e)->Sphere, (f)->Disc for the Karlsruhe hand.
    assert [robot_grasp_for(g, "barrett") for g in GRASP_CLASSES] == [
        "Wrap", "Wrap", "Two-finger Thumb", "Two-finger Thumb", "Precision Disc", "Precision Disc"]
    assert [robot_grasp_for(g, "karlsruhe") for g in GRASP_CLASSES] == [
        "Power", "Wrap", "Power", "Power", "Sphere", "Disc"]
    # IROS 2008 Fig. 2: (a,b,c,e)->Wrap, (d)->Two-finger Thumb, (f)->Precision Disc.
    assert robot_grasp_for(10, "barrett", "iros2008") == "Wrap"
    assert robot_grasp_for(9, "barrett", "iros2008") == "Two-finger Thumb"


@pytest.mark.parametrize("grasp", GRASP_CLASSES)
def test_objects_rest_on_a_plane(grasp):
    obj = GRASP_OBJECTS[grasp]
    xml = (f'<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>'
           f'<body pos="0 0 {obj.rest_height_m + 0.002}"><freejoint/>{obj.geom_xml()}</body>'
           f'</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=500)
    assert data.qpos[2] == pytest.approx(obj.rest_height_m, abs=2e-3)  # resting, not sunk nor toppled


def test_bad_names_raise():
    with pytest.raises(ValueError, match="grasp"):
        check_grasp_class(3)
    with pytest.raises(ValueError, match="hand"):
        robot_grasp_for(1, "shadow")
    with pytest.raises(ValueError, match="mapping"):
        robot_grasp_for(1, "barrett", "paper")
