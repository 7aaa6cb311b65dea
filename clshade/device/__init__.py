"""Device stage: model × scene features → kernel variant → OpenCL dispatch → radiance.

Reads the G-buffer the render stage wrote; never imports verify/ or bench/.
"""
