"""The BioTac SP layout shared by the reference generators in this directory: skin electrode
positions (mm) of the COMSOL BioTac SP model (B. Sadrfaridpour, `bsadr/biotac`), electrodes 1..24, as
in gradtac_stream::Layout::biotac_sp, and its cylindrical arc-length unwrap
x_mm = x, y_mm = rho * atan2(y, -z), rho = hypot(y, z).
"""
import math

SKIN = [
    [11.14857, -5.25733, -3.65186], [9.28813, -4.13207, -7.01911], [2.46644, -9.07826, -4.139],
    [2.40223, -6.68511, -7.82462], [-0.53737, -3.19441, -10.10018], [-2.59071, -9.15067, -3.86751],
    [-3.9217, -6.23412, -7.91412], [-6.51216, -2.45585, -9.2922], [-9.36007, -4.39204, -6.8576],
    [-11.48363, -5.10487, -3.36957], [11.15987, 5.26812, -3.65935], [9.30141, 4.144, -7.03937],
    [2.46665, 9.07986, -4.13973], [2.40237, 6.68595, -7.8256], [-0.53735, 3.19416, -10.09939],
    [-2.59194, 9.15986, -3.8714], [-3.9194, 6.22657, -7.90454], [-6.5019, 2.44801, -9.26256],
    [-9.33708, 4.37031, -6.82367], [-11.46739, 5.09033, -3.35997], [7.3143, 0.0, -9.38526],
    [5.04212, -1.8519, -9.85908], [5.04983, 1.8519, -9.88999], [2.64671, 0.0, -10.51272],
]


def biotac_positions():
    """The unwrapped (x_mm, y_mm) of electrodes 1..24."""
    return [[x, math.hypot(y, z) * math.atan2(y, -z)] for x, y, z in SKIN]
