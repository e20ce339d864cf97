"""An I++ DME server that answers every command as a CMM would (a PtMeas touching at its
nominal point with a 1 mm ball) and then drops the connection, or keeps silent: what a live run
does when the CMM's link fails."""
import re
import socket
import threading

import numpy as np


def touched(command):
    """'X(..), Y(..), Z(..), IJK(..)' of a PtMeas command's ball centre where it touches at the
    nominal point (a 1 mm ball)."""
    values = dict(re.findall(r"([A-Z]+)\(([^()]*)\)", command))
    vector = np.array([float(v) for v in values["IJK"].split(",")])
    centre = np.array([float(values[axis]) for axis in "XYZ"]) + vector
    return f"X({centre[0]:.6f}), Y({centre[1]:.6f}), Z({centre[2]:.6f}), IJK({values['IJK']})"


def serve_then_drop(commands_before_drop, answers=True):
    """A server that answers like I++ (& then %) and closes after some commands (or, not
    answering, keeps silent until the client goes); its address."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(1)

    def run():
        connection, _ = listener.accept()
        stream = connection.makefile("rb")
        for count in range(commands_before_drop):
            line = stream.readline().decode().strip()
            tag = line.split(" ")[0]
            method = line.split(" ")[1].split("(")[0]
            data = ([f"{tag} # {touched(line)}, ER(1)"] if method == "PtMeas" else
                    {"IsHomed": [f"{tag} # IsHomed(1)"], "EnumTools": [f'{tag} # "Probe1"']}.get(method, []))
            if answers:
                connection.sendall("".join(f"{a}\r\n" for a in [f"{tag} &", *data, f"{tag} %"]).encode())
        if not answers:
            stream.read()   # silent until the client goes
        connection.close()
        listener.close()

    threading.Thread(target=run, daemon=True).start()
    return "127.0.0.1:%d" % listener.getsockname()[1]
