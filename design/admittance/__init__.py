"""The admittance controller (m_v, b_v) for mouse following: its model, synthesis and verification."""
