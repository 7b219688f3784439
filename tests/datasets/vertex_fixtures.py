"""Small corpora in the BIWI and Multiface layouts, made from the posed synthetic corpus.

The synthetic corpus's FLAME meshes are refined to the target vertex count by
inserting triangle centroids (each new vertex the mean of three existing ones, so
FLAME's vertex indices, landmarks included, keep their meaning), resampled to the
corpus's rate and written in exactly its file formats.
"""

import pickle

import numpy as np
import scipy.sparse as sp

from blendvoca.assets import load_index_list
from blendvoca.fit.resample import resample_sequence
from blendvoca.io.audio import write_wav
from blendvoca.io.mesh import write_obj, write_ply
from blendvoca.runtime.progress import progress_bars
from blendvoca.synthetic import generate_corpus, read_npz
from blendvoca.vocaset import open_vocaset


def refine(faces, num_base, num_vertices):
    """Faces and the (num_vertices, num_base) averaging matrix of centroid insertions up to num_vertices."""
    faces = np.asarray(faces, dtype=np.int64)
    parents = sp.identity(num_base, format="csr")
    count = num_base
    while count < num_vertices:
        take = min(len(faces), num_vertices - count)
        split, kept = faces[:take], faces[take:]
        new = np.arange(count, count + take)
        mix = sp.csr_matrix((np.full(3 * take, 1.0 / 3.0), (np.repeat(np.arange(take), 3), split.ravel())),
                            shape=(take, count)) @ parents
        parents = sp.vstack([parents, mix]).tocsr()
        faces = np.concatenate([kept, np.stack([split[:, 0], split[:, 1], new], 1),
                                np.stack([split[:, 1], split[:, 2], new], 1),
                                np.stack([split[:, 2], split[:, 0], new], 1)])
        count += take
    return faces, parents


def posed_source(root):
    """The posed synthetic corpus (3 speakers, 1 sentence of ~1 s, seed 0) with its truth."""
    with progress_bars(False):  # no bar in a test's captured stderr
        corpus = generate_corpus(root, speakers=3, sentences=1, seed=0, duration=(1.0, 1.1), head_motion=True)
    return open_vocaset(corpus), corpus


def write_biwi(root, source, speakers=("F2", "F1", "F5"), scale=1.0, num_vertices=23370):
    """BIWI's FaceFormer layout: templates.pkl, vertices_npy/<S>_e01.npy (T, 70110) float32 at 25 fps,
    wav/<S>_e01.wav, BIWI.ply."""
    corpus, _ = source
    faces, up = refine(corpus.faces, 5023, num_vertices)
    (root / "vertices_npy").mkdir(parents=True)
    (root / "wav").mkdir()
    templates = {}
    for name, subject in zip(speakers, corpus.subjects):
        templates[name] = (up @ corpus.template(subject)) * scale
        frames = resample_sequence(corpus.posed_frames(subject, "sentence01"), 60, 25)
        moved = np.stack([up @ frame for frame in frames])
        np.save(root / "vertices_npy" / f"{name}_e01.npy",
                (moved * scale).reshape(len(moved), -1).astype(np.float32))
        samples, rate = corpus.audio(subject, "sentence01")
        write_wav(root / "wav" / f"{name}_e01.wav", samples, rate)
    with open(root / "templates.pkl", "wb") as f:
        pickle.dump(templates, f, protocol=2)
    write_ply(root / "BIWI.ply", templates[speakers[0]], faces)
    return root


def write_multiface(root, source, captures=("m--20180227--0000--6795937--GHS", "m--20180406--0000--8870559--GHS",
                                             "m--20180927--0000--7889059--GHS"), fmt="bin", scale=1000.0,
                    num_vertices=6172):
    """Multiface in MeshTalk's topology: face_template.obj, <capture>/tracked_mesh/SEN_x/<frame>.bin|obj
    (float32 x, y, z at 30 fps, millimetres, frame numbers from the capture), <capture>/audio/SEN_x.wav,
    <capture>/tracked_mesh/EXP_neutral_peak/<frame>.bin (the neutral)."""
    corpus, _ = source
    faces, up = refine(corpus.faces, 5023, num_vertices)
    root.mkdir(parents=True, exist_ok=True)
    for k, (name, subject) in enumerate(zip(captures, corpus.subjects)):
        neutral = root / name / "tracked_mesh" / "EXP_neutral_peak"
        neutral.mkdir(parents=True)
        template = (up @ corpus.template(subject)) * scale
        template.astype("<f4").tofile(neutral / "000100.bin")
        if k == 0:
            write_obj(root / "face_template.obj", template, faces)
        sentence = root / name / "tracked_mesh" / "SEN_oh_we_managed_she_said"
        sentence.mkdir(parents=True)
        frames = resample_sequence(corpus.posed_frames(subject, "sentence01"), 60, 30)
        for t, frame in enumerate(frames):
            vertices = (up @ frame) * scale
            if fmt == "bin":
                vertices.astype("<f4").tofile(sentence / f"{21897 + t:06d}.bin")
            else:
                write_obj(sentence / f"{21897 + t:06d}.obj", vertices, faces)
        (root / name / "audio").mkdir()
        samples, rate = corpus.audio(subject, "sentence01")
        write_wav(root / name / "audio" / "SEN_oh_we_managed_she_said.wav", samples, rate)
    return root


def write_landmarks(path):
    """FLAME's 68 landmarks: the refined meshes keep FLAME's first 5023 vertices."""
    path.write_text(" ".join(str(int(i)) for i in load_index_list("flame-landmarks")) + "\n")
    return path


def truth(source, index):
    """(rotations, translations) of speaker ``index``'s sentence at 60 fps."""
    corpus, root = source
    data = read_npz(root / "groundtruth" / corpus.subjects[index] / "sentence01.npz")
    return data["head_rotations"], data["head_translations"]
