"""Renders a scene written by `wavepath mitsuba` with Mitsuba 3 (LLVM
variant, all cores) and prints where the time went. Used by mitsuba.sh.

usage: python mitsuba_render.py scene.xml out.exr
"""
import sys, time
t0 = time.perf_counter()
import mitsuba as mi
mi.set_variant('llvm_ad_rgb')
t1 = time.perf_counter()
scene = mi.load_file(sys.argv[1])
t2 = time.perf_counter()
img = mi.render(scene)
import drjit as dr
dr.eval(img); dr.sync_thread()
t3 = time.perf_counter()
mi.Bitmap(img).write(sys.argv[2])
t4 = time.perf_counter()
print(f"import {t1-t0:.3f} s | load {t2-t1:.3f} s | render {t3-t2:.3f} s | write {t4-t3:.3f} s | total {t4-t0:.3f} s")
