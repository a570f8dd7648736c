"""What every column of ``data/*.parquet`` and every array of ``media/*.h5`` means: one table,
used by the writer (column order), ``fallgen validate`` (required columns) and the dataset card.

Frames and units: the room frame has its origin at the floor's south-west corner, x east, y
north, z up, metres; quaternions are (w, x, y, z); headings are integers 0..11 in 30 degree steps
counter-clockwise from +x; camera tilt is in degrees, up positive.
"""

from __future__ import annotations

#: column -> (Arrow type as written, unit, meaning)
COLUMNS: dict[str, tuple[str, str, str]] = {
    "episode_id": ("int64", "", "0 .. N-1 over the build: splits in order train, validation, "
                   "test; within a split kitchens, then study rooms"),
    "split": ("string", "", "train, validation or test"),
    "event_id": ("string", "", "the rehearsed fall event (rehearsal/*.parquet) the episode "
                 "replays"),
    "room_variant": ("string", "", "room-layout-materials, e.g. kitchen_galley-l1-m1"),
    "room_kind": ("string", "", "kitchen or study (the cross-scene splits filter on it)"),
    "zone": ("string", "", "fall zone id within the variant (z00..z19)"),
    "zone_kind": ("string", "", "floor, table_top, shelf, cabinet_top, box, basket, pan, "
                  "under_furniture, behind_furniture, ..."),
    "category": ("string", "", "object category (30)"),
    "variant": ("string", "", "the category's mesh variant"),
    "material": ("string", "", "the object's physical material"),
    "audio_material": ("string", "", "its audio material class (14)"),
    "scale": ("double", "", "uniform scale applied to the mesh variant"),
    "mass_kg": ("double", "kg", "object mass"),
    "start_pos": ("list<double>[3]", "m", "release position (room frame)"),
    "start_quat": ("list<double>[4]", "", "release orientation (w, x, y, z)"),
    "settle_pos": ("list<double>[3]", "m", "resting position of the object's body frame"),
    "settle_quat": ("list<double>[4]", "", "resting orientation (w, x, y, z)"),
    "settle_time_s": ("double", "s", "time from release to rest"),
    "contacts": ("int64", "", "contact events of the fall (rehearsal)"),
    "fall_height_m": ("double", "m", "how far the object's centre of mass falls before its "
                      "first contact (at least the rehearsal's min_fall_m)"),
    "spawn_x": ("double", "m", "robot spawn position x"),
    "spawn_y": ("double", "m", "robot spawn position y"),
    "spawn_heading": ("int64", "30 deg", "spawn heading 0..11, counter-clockwise from +x"),
    "spawn_yaw_rad": ("double", "rad", "spawn heading in radians"),
    "spawn_sees_object": ("bool", "", "true when every spawn draw already saw the object "
                          "(kept; rare)"),
    "expert_actions": ("list<int64>", "", "shortest-path expert: indices into the HDF5 attribute "
                       "'actions' (move_forward, turn_left, turn_right, look_up, look_down, "
                       "found); ends with found"),
    "expert_poses": ("list<list<double>[4]>", "m, m, 30 deg, deg",
                     "(x, y, heading, tilt) at the spawn, then after each expert action"),
    "expert_path_m": ("double", "m", "distance the expert travels"),
    "shortest_path_m": ("double", "m", "shortest path length in the action lattice to a pose "
                        "that sees the object (SPL's reference)"),
    "fewest_actions": ("int64", "", "fewest actions that succeed (SNA's reference)"),
    "expert_spl": ("double", "", "the expert's SPL (1 by construction)"),
    "expert_sna": ("double", "", "the expert's SNA"),
    "goal_x": ("double", "m", "expert's final position x"),
    "goal_y": ("double", "m", "expert's final position y"),
    "goal_heading": ("int64", "30 deg", "expert's final heading"),
    "goal_tilt_deg": ("int64", "deg", "expert's final camera tilt"),
    "target_cell": ("list<int64>[2]", "cell", "the object's cell in the occupancy map"),
    "grid_resolution_m": ("double", "m", "occupancy cell size"),
    "audio_gain": ("double", "", "audio = ear pressure / 20 Pa * audio_gain (1 unless the "
                   "clip would pass 0.99)"),
    "audio_peak_db_spl": ("double", "dB SPL", "the fall's peak ear pressure, louder ear "
                          "(without the noise floor)"),
    "audio_leq_db_spl": ("double", "dB SPL", "the fall's loudest 125 ms equivalent level, "
                         "louder ear (without the noise floor)"),
    "audio_noise_db_a": ("double", "dB(A)", "the ambient noise floor mixed into the clip "
                         "(a quiet home's: RC neutral spectrum, diffuse between the ears; 0: "
                         "none), its A-weighted level over the clip"),
    "audio_radiated_j": ("double", "J", "acoustic energy the fall's dry sound radiates (every "
                         "source, its pressure at 1 m taken as the same in every direction)"),
    "fall_energy_lost_j": ("double", "J", "mechanical energy the fall loses in its contacts "
                           "(m g times the centre of mass's drop, plus the start's kinetic "
                           "energy)"),
    "audio_energy_ratio": ("double", "", "audio_radiated_j / fall_energy_lost_j: hard impacts "
                           "radiate ~1e-4 to 1e-2 of their energy, soft ones far less; every "
                           "build checks it against AUDIO_ENERGY_CEILING (fallgen stats)"),
    "first_impact_surface": ("string", "", "the material the fall's first impact struck (its "
                             "audio material and finish: stone, wood_medium, fabric/rug...; "
                             "empty without an impact): fallgen stats judges the energy "
                             "ratio's median on hard objects' falls onto hard surfaces"),
    "room_rt60_s": ("list<double>[7]", "s", "the furnished room's reverberation time per "
                    "octave band, 125 Hz .. 8 kHz (Arau-Puchades over the walls and the "
                    "furniture's exposed faces: the clip's late reverb decays with it)"),
    "sample_rate": ("int64", "Hz", "audio sample rate (44100)"),
    "instance_labels": ("string", "", "JSON list: instance segmentation value k -> "
                        "owner name (k = 0: nothing)"),
    "root_seed": ("int64", "", "the build's root seed; the episode's generator is "
                  "SeedSequence(root_seed, spawn_key=(episode_id,))"),
    "event_attempts": ("int64", "", "events tried for this episode (1 = its planned event)"),
    "skipped_events": ("string", "", "JSON list of [event_id, reason] tried before the one "
                       "used"),
    "media_file": ("string", "", "HDF5 file holding the episode's arrays (relative path)"),
    "media_index": ("int64", "", "the episode's row in that file's arrays"),
}

#: HDF5 arrays per shard: name -> (shape, dtype, unit, meaning)
ARRAYS: dict[str, tuple[str, str, str, str]] = {
    "audio": ("(N, 2, T)", "float32", "Pa / 20", "binaural ear pressure (row 0 left ear) "
              "times audio_gain, T = audio_s x 44100"),
    "rgb": ("(N, 300, 300, 3)", "uint8", "", "egocentric colour image at step 0 (90 deg FOV, "
            "camera 1.1 m above the floor, tilt 0)"),
    "depth": ("(N, 300, 300)", "float16", "m", "distance along the optical axis"),
    "instance": ("(N, 300, 300)", "int16", "", "instance segmentation (instance_labels)"),
    "category": ("(N, 300, 300)", "int16", "", "category segmentation (file attribute "
                 "category_labels)"),
    "occupancy/{k}": ("(1, nx, ny)", "uint8", "0.1 m cells", "1 = occupied in the robot's "
                      "height band, x-major (cell [i, j] covers x in [i, i+1) x 0.1 m)"),
    "frames/{k}/rgb|depth|instance": ("(n+1, 300, 300[, 3])", "as above", "",
                                       "views at expert_poses (builds with frames = "
                                       "'trajectory' only)"),
}

REQUIRED = tuple(c for c in COLUMNS)
