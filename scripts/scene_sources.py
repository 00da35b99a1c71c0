"""Where the imported scenes come from: the source repository, the folders held out, each scene's author,
licence and framing (the lines of its README that are not changes)."""
from __future__ import annotations

REPOSITORY = "https://github.com/hchoi405/dppm-scenes"
DEFAULT_NAMES = ("dining-room", "living-room", "sponza", "veach-lamp")
HELD_OUT = ("classroom", "staircase")
#: scenes imported only for the GAN's training data (``gmcpt dataset --real``): none is an evaluation scene
TRAINING_NAMES = ("bathroom", "bathroom2", "living-room-2", "spaceship")

BITTERLI = "https://benedikt-bitterli.me/resources/"
CC_BY = "CC BY 3.0, https://creativecommons.org/licenses/by/3.0/"
CC0 = "CC0 1.0 (public domain), https://creativecommons.org/publicdomain/zero/1.0/"
MITSUBA_SCENES = "https://www.mitsuba-renderer.org/download.html"


def _camera_kept(fov: str, native: str, square: str) -> str:
    return f"source camera kept (fov {fov}): the native {native} view is the author's; a 256x256 film {square}"


def _mitsuba_example(name: str) -> str:
    return (f"not stated: no licence file in the source; it appears to be the Mitsuba 0.6 example scene `{name}` "
            f"({MITSUBA_SCENES}), published for use with Mitsuba")


TRAINING_FRAMING = ("source camera and its rand_sceneN variants kept; the dataset builder (`gmcpt dataset --real`) "
                    "renders them square, jittered and cropped")

def _bitterli_training(title: str, author: str, blend: int, licence: str, what: str) -> dict:
    """A training-only scene from Bitterli's Rendering Resources, whose folder carries a LICENSE.txt."""
    return dict(title=title, author=f"{author} (Blender scene, http://www.blendswap.com/blends/view/{blend})",
                licence=licence, framing=TRAINING_FRAMING,
                provenance=f"Benedikt Bitterli's Rendering Resources ({BITTERLI}), Mitsuba version; licence from "
                           "the folder's LICENSE.txt (copied here).",
                use=f"Training only (GAN data, never evaluated): {what}")


#: what is known of each scene's origin, and how its camera frames a 256x256 and the native film
SCENES = {
    "dining-room": dict(
        title="The Breakfast Room", author="Wig42 (Blender scene, http://www.blendswap.com/blends/view/75431)",
        licence=CC_BY,
        provenance="Benedikt Bitterli's Rendering Resources (" + BITTERLI + "), Mitsuba version; the dppm-scenes "
                   "folder has no LICENSE.txt; Bitterli's release of this scene (same camera), as copied in gmcpt's "
                   "../shared/scenes/breakfast-room, carries one naming Wig42 and CC BY 3.0. It is the scene of "
                   "gmcpt's `breakfast-room`, here lit by its sun and sky instead of a constant emitter.",
        notes="sun and sky through open windows (no glass), reachable by path tracing; the floor and the lower "
              "third stay dark (a third of the pixels below 0.01 at 256x256)",
        framing=_camera_kept("60 on x", "1280x720", "keeps its width and adds floor and ceiling (table, chairs, "
                             "lamps, painting, window in view)")),
    "living-room": dict(
        title="The Grey & White Room", author="Wig42 (Blender scene, http://www.blendswap.com/blends/view/75795)",
        licence=CC_BY,
        provenance="Benedikt Bitterli's Rendering Resources (" + BITTERLI + "), Mitsuba version; licence from the "
                   "folder's LICENSE.txt (copied here).",
        notes="environment map through open windows; bright and well lit, strong fireflies at low spp",
        framing=_camera_kept("90 on x", "1280x720", "keeps its width and adds floor and ceiling (windows, table, "
                             "sofa in view)")),
    "sponza": dict(
        title="Sponza Atrium", author="Marko Dabrovic (original 2002 model); Mitsuba conversion from COLLADA",
        licence="not stated: no licence file in the source; the model has long been redistributed freely for "
                "rendering research - credit Marko Dabrovic, and check its terms before publishing images",
        provenance="dppm-scenes folder `sponza`; the scene file says only 'Automatically converted from COLLADA' "
                   "(its `sponza.serialized` and textures appear to be the Mitsuba 0.6 example scene, "
                   + MITSUBA_SCENES + ").",
        notes="one small spherical light above the atrium; evenly lit, little black",
        framing=_camera_kept("96.7 on x", "1280x720", "keeps its width and adds floor and vault")),
    "veach-lamp": dict(
        title="Lamp and egg room (bidirectional test scene)",
        author="after the test scene of Eric Veach's thesis (1997); modeller of this version not stated",
        licence=_mitsuba_example("bidir") + " - credit Eric Veach",
        provenance="dppm-scenes folder `veach-lamp` (mesh file `bidir.serialized`); the scene file says only "
                   "'Automatically converted from COLLADA'.",
        notes="lamps aimed at the ceiling and a wall: almost all light is indirect, noisy at low spp; a hard case",
        framing=_camera_kept("57.3 on x", "1024x576", "keeps its width and adds floor and ceiling (both lamps, "
                             "table, egg in view)")),
    "box": dict(
        title="Box with glass and metal objects", author="not stated in the source",
        licence="unknown: no licence file and no attribution in the source; do not publish images of it "
                "without finding its origin",
        provenance="dppm-scenes folder `box`; the scene file says only 'Automatically converted from Wavefront OBJ'.",
        notes="mostly black: its two tiny lights are seen only through specular paths - a bad evaluation scene",
        framing=_camera_kept("35 on y", "800x600", "keeps its height and loses the sides")),
    "torus": dict(
        title="Torus in a glass cube", author="not stated in the source (a Rhino 5.0 model)",
        licence=_mitsuba_example("torus"),
        provenance="dppm-scenes folder `torus`; the scene file says 'Automatically converted from Rhino 5.0'.",
        notes="sun and sky on a floor, the torus inside a glass cube: mostly caustics and refraction",
        framing=_camera_kept("34.6 on x", "1024x768", "keeps its width and adds floor")),
    "bathroom": _bitterli_training("Contemporary Bathroom", "Mareck", 75302, CC0,
                                   "a small bathroom lit by one area light"),
    "bathroom2": dict(
        title="Bathroom (tiles, mirror, glass)", author="not stated in the source",
        licence="not stated: no licence file in the source; used only to render training data here, "
                "never published as images",
        provenance="dppm-scenes folder `bathroom2` (its meshes are Mitsuba `.serialized` files).",
        use="Training only (GAN data, never evaluated): tiled bathroom lit by a window area light; its "
            "environment texture is missing from the snapshot, so a uniform grey takes its place",
        framing=TRAINING_FRAMING),
    "living-room-2": _bitterli_training("The White Room", "Jay-Artist", 41683, CC_BY,
                                        "white living room lit through its windows"),
    "spaceship": _bitterli_training("4060.b Spaceship", "thecali", 75686, CC0,
                                    "a studio model under area lights, not an interior"),
}
