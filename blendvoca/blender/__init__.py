"""Blender integration: :mod:`blendvoca.blender.blendvoca_addon` is a Blender add-on
(install the file from Blender's Preferences > Add-ons > Install from Disk) that imports
a BlendVOCA rig as shape keys and a coefficient track as keyframes with its audio as a
sound strip. Its functions also run headless with the ``bpy`` package."""
