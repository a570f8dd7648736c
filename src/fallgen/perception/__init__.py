"""Perception modules learned from a built dataset: what an agent can infer from its
sensors before it moves. :mod:`fallgen.perception.audio_features` turns a step-0 binaural clip
into a feature vector; :mod:`fallgen.perception.audio_model` learns the fallen object's
category, its audio material and where the fall was (azimuth and distance from the agent) from
a build's train split, and scores itself on another split against a no-audio prior."""
