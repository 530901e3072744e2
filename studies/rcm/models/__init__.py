"""The RCM controller's models: the constraint dynamics, the energy side (passivity, capsule,
cloud cover) and the numeric Lyapunov certificate."""
