"""Physics: dropping objects in room scenes, detecting settling, recording contacts."""
