"""Names of the inputs the readers take, importable without numpy or h5py.

The command line lists them in ``--help`` and checks options against them before any reader
is loaded. The readers (:mod:`mimucap.io.orientation_tables`, :mod:`mimucap.io.magdata`)
import them from here.
"""

#: Kinds of orientation input (:func:`mimucap.io.orientation_inputs.orientation_input_kind`),
#: each named as a message says it.
XSENS_FOLDER = "Xsens export folders"
XSENS_FILE = "Xsens export files"
OPENSIM_STO = "OpenSim .sto tables"
MIMUCAP_SESSION = "MimuCap sessions"
BROAD_TRIAL = "BROAD trials"
APDM_CSV = "APDM CSV files"
QUATERNION_CSV = "quaternion CSV files"
#: Suffixes that mark a file as a MimuCap session, whatever its first bytes.
SESSION_SUFFIXES = (".h5", ".hdf5", ".mimucap")

#: Units of magnetometer samples (:mod:`mimucap.io.magdata`).
MAG_UNITS = ("uT", "gauss", "counts")
#: File formats of magnetometer samples (:func:`mimucap.io.magdata.read_mag_files`).
FORMATS = ("auto", "csv", "xsens", "session")
