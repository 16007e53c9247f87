"""What the controller runs on top of the motion core: admittance and force control, velocity control
(modes 4/5), online planning (modes 6/7), trajectory recording and playback, reduced mode and load
identification, and the table of modes beyond the manual's (:mod:`.modes`).
"""
