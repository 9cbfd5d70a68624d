"""The table of clinical names: every machine name of the built-in models has a readable,
unique label, and the axis meanings follow the conventions."""

import pytest

from mimucap.core import clinical_names as names
from mimucap.core import skeleton


@pytest.mark.parametrize("model_name", skeleton.MODEL_NAMES)
@pytest.mark.parametrize("sequence", skeleton.SHOULDER_SEQUENCES)
def test_every_column_of_every_model_has_a_unique_readable_label(model_name, sequence):
    model = skeleton.load_model(model_name)
    columns = skeleton.joint_angle_columns(model, sequence)
    labels = [names.angle_label(c) for c in columns]
    assert len(set(labels)) == len(labels)
    for column, label in zip(columns, labels):
        assert "_" not in label and label.endswith(" (°)"), (column, label)
        assert label[0].isupper()
        joint, _axis = names.split_angle_column(column)
        assert joint in model.joint_names
    segments = [names.segment_name(s) for s in model.segment_names]
    assert len(set(segments)) == len(segments) and all("_" not in s for s in segments)


@pytest.mark.parametrize("column, label, sign", [
    ("knee_r_flexion_deg", "Right knee flexion (°)", "+ flexion / − extension"),
    ("hip_l_adduction_deg", "Left hip adduction (°)", "+ adduction / − abduction"),
    ("hip_l_rotation_deg", "Left hip internal rotation (°)", "+ internal rotation / − external rotation"),
    ("ankle_r_flexion_deg", "Right ankle dorsiflexion (°)", "+ dorsiflexion / − plantarflexion"),
    ("ankle_l_adduction_deg", "Left ankle inversion/eversion (°)", "+ inversion / − eversion"),
    ("knee_r_adduction_deg", "Right knee varus/valgus (°)", "+ varus / − valgus"),
    ("knee_l_rotation_deg", "Left knee internal rotation (°)", "+ internal rotation / − external rotation"),
    ("elbow_r_adduction_deg", "Right elbow carrying angle (°)", "+ varus / − valgus"),
    ("elbow_l_rotation_deg", "Left elbow pronation/supination (°)", "+ pronation / − supination"),
    ("wrist_r_adduction_deg", "Right wrist ulnar/radial deviation (°)", "+ ulnar deviation / − radial deviation"),
    ("lumbar_adduction_deg", "Lumbar spine lateral bending (°)", "+ lateral bending right / − lateral bending left"),
    ("neck_rotation_deg", "Neck axial rotation (°)", "+ axial rotation left / − axial rotation right"),
    ("shoulder_l_plane_of_elevation_deg", "Left shoulder plane of elevation (°)",
     "plane of elevation (0° abduction, 90° forward flexion)"),
    ("shoulder_r_elevation_deg", "Right shoulder elevation (°)", "elevation"),
])
def test_labels_and_signs_follow_the_conventions(column, label, sign):
    assert names.angle_label(column) == label
    assert names.angle_sign_text(column) == sign


def test_segments_and_sensors():
    assert names.segment_name("upper_arm_l") == "Left upper arm"
    assert names.segment_name("pelvis") == "Pelvis"
    assert names.sensor_name("pelvis") == "Pelvis sensor"
    assert names.sensor_name("shank_r", "7") == "Right shank sensor (7)"
    assert names.sensor_name(None, "7") == "Sensor 7"
    assert names.joint_name("lumbar") == "Lumbar spine"
    # a name no table knows is spelled out, not refused (models can come from files)
    assert names.segment_name("lower_back") == "Lower back"
    assert names.angle_label("t_s") == "Time (s)"
    assert names.angle_label("pelvis_tilt") == "Pelvis tilt"


def test_a_column_that_is_not_a_joint_angle_is_refused_by_split():
    for column in ("knee_r_flexion", "flexion_deg", "knee_r_bend_deg"):
        with pytest.raises(ValueError, match="joint-angle column"):
            names.split_angle_column(column)


def test_messages_get_sided_machine_names_in_words():
    assert names.in_clinical_words("the right arm has no sensor in the mapping (map upper_arm_r)") == \
        "the right arm has no sensor in the mapping (map right upper arm)"
    assert names.in_clinical_words("knee_l and shank_r; pelvis; thigh_rx stays") == \
        "left knee and right shank; pelvis; thigh_rx stays"
