"""Passive RCM admittance control with forbidden regions (KUKA LWR4+, 250 Hz): the models of the
paper's Theorem 1, the arm, cloud and dynamics runtime, the push search, and the generated axial guard."""
