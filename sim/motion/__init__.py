"""Source motion shared by the renderer and the articulated characters: quaternions and DeepMimic clips."""
