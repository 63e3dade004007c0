"""Files of the demo: PLY clouds (read) and colour-mapped depth images (written)."""
import cv2
import numpy as np


def read_ply(path, with_faces=False):
    """(xyz float64 N x 3, rgb uint8 N x 3) of a binary little-endian PLY whose
    vertices hold float x y z and uchar red green blue among other properties;
    with_faces: also its triangles (int M x 3; none when it has no "face"
    element of uchar-counted int indices, as amhmvs writes meshes)."""
    types = {"float": "<f4", "float32": "<f4", "double": "<f8", "uchar": "u1", "uint8": "u1",
             "int": "<i4", "uint": "<u4", "short": "<i2", "ushort": "<u2", "char": "i1"}
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise ValueError(f"{path}: not a PLY file")
        fields, count, faces, element = [], 0, 0, None
        while True:
            words = f.readline().decode("ascii").split()
            if not words:
                raise ValueError(f"{path}: PLY header without end_header")
            if words[0] == "end_header":
                break
            if words[0] == "format" and words[1] != "binary_little_endian":
                raise ValueError(f"{path}: only binary_little_endian PLY is read, not {words[1]}")
            if words[0] == "element":
                element = words[1]
                count = int(words[2]) if element == "vertex" else count
                faces = int(words[2]) if element == "face" else faces
            elif words[0] == "property" and element == "vertex":
                fields.append((words[2], types[words[1]]))
            elif words[0] == "property" and element == "face" and words[1:4] != ["list", "uchar", "int"]:
                raise ValueError(f"{path}: faces must be 'list uchar int', not {' '.join(words[1:4])}")
        vertex = np.fromfile(f, dtype=np.dtype(fields), count=count)
        triangles = np.fromfile(f, dtype=np.dtype([("n", "u1"), ("i", "<i4", (3,))]), count=faces)
    xyz = np.stack([vertex[n] for n in "xyz"], axis=1).astype(np.float64)
    rgb = np.stack([vertex[n] for n in ("red", "green", "blue")], axis=1).astype(np.uint8)
    if not with_faces:
        return xyz, rgb
    if np.any(triangles["n"] != 3):
        raise ValueError(f"{path}: only triangles are read")
    return xyz, rgb, triangles["i"].astype(np.int64)


# The colour map of every depth picture of the project (src/io/depth_preview.cpp):
# viridis, black where there is no depth, a scale bar below labelled in metres.
SCALE_BAR_ROWS = 22


def colour_depth(depth, near, far):
    """BGR viridis colour map of depth over [near, far], black where NaN."""
    scaled = np.clip((np.nan_to_num(depth, nan=far) - near) / max(far - near, 1e-6), 0, 1)
    image = cv2.applyColorMap((255 * scaled).astype(np.uint8), cv2.COLORMAP_VIRIDIS)
    image[~np.isfinite(depth)] = 0
    return image


def scale_bar(width, near, far):
    """A bar from near (left) to far (right) with both ends labelled."""
    bar = np.zeros((SCALE_BAR_ROWS, width, 3), np.uint8)
    bar[2:10] = colour_depth(np.linspace(near, far, width)[None, :], near, far)
    for text, right in ((f"{near:.2f} m", False), (f"{far:.2f} m", True)):
        (w, _), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.35, 1)
        cv2.putText(bar, text, (width - w - 1 if right else 1, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.35,
                    (255, 255, 255), 1, cv2.LINE_AA)
    return bar


def colour_depth_pair(estimate, truth, path):
    """Writes estimate | ground truth side by side on the ground truth's depth
    range, with the scale bar below."""
    finite = truth[np.isfinite(truth)]
    near, far = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    gap = np.zeros((estimate.shape[0], 4, 3), np.uint8)
    pair = np.hstack([colour_depth(estimate, near, far), gap, colour_depth(truth, near, far)])
    if not cv2.imwrite(path, np.vstack([pair, scale_bar(pair.shape[1], near, far)])):
        raise IOError(f"{path}: cannot write")
