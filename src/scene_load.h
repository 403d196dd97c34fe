/*
 * scene_load.h -- scenes from specs and files (prefix rt_scene_load): the
 * loaders and the dispatch over them. The container they fill is scene.h;
 * this header sits above it (scene.h includes nothing of the loaders).
 *
 * Scene specs: a built-in name with optional parameters, e.g.
 *   "sphereflake", "sphereflake:level=2,tess=3", "grove:trees=4",
 * or a path ending in .obj, .ply or .pbrt (each also with .gz after it);
 * any spec may end in
 * material=PRESET (rt_scene_set_material).
 */
#ifndef RT_SCENE_LOAD_H
#define RT_SCENE_LOAD_H

#include "scene.h"

/* Built-in scene names, NULL-terminated. */
extern const char *const rt_scene_builtin_names[];
/* One-line description of a built-in scene, or NULL if unknown. */
const char *rt_scene_describe(const char *name);

/* Makes a scene from a spec (built-in name[:k=v,...] or .obj/.ply path).
 * Returns NULL with a one-line message on failure. Free with rt_scene_free. */
rt_scene *rt_scene_load(const char *spec, rt_err *e);
rt_scene *rt_scene_builtin(const char *name, const char *params, rt_err *e);
rt_scene *rt_scene_load_obj(const char *path, rt_err *e);
rt_scene *rt_scene_load_ply(const char *path, rt_err *e);
/* A pbrt-v4 scene file (subset: docs/scenes.md, "pbrt"). params: "" or
 * "tess=N" (sphere tessellation, 1..64, default 3), "maxtri=N" (refuse
 * scenes above N triangles, default 2^26) and "maxsubdiv=N" (refuse a
 * loopsubdiv shape above N triangles, default 2^22). Plain or gzip files
 * (scene_file.h), told by content. */
rt_scene *rt_scene_load_pbrt(const char *path, const char *params, rt_err *e);
/* The same with RT_LOAD_* flags: RT_LOAD_KEEP_INSTANCES keeps the
 * instances unflattened (scene.h, "Kept instances"). */
rt_scene *rt_scene_load_pbrt_flags(const char *path, const char *params, unsigned flags, rt_err *e);
/* rt_scene_load with RT_LOAD_* flags (they concern .pbrt files; other
 * scenes load as rt_scene_load makes them). */
rt_scene *rt_scene_load_flags(const char *spec, unsigned flags, rt_err *e);
/* For an image W x H whose aspect differs from the scene's Film (a pbrt
 * file's xresolution x yresolution; scenes without one are left alone),
 * keeps the film's horizontal extent: the vertical field of view becomes
 * 2 atan(tan(fovy/2) x (film_w / film_h) x (H / W)), and a warning of kind
 * "image aspect" is recorded. 1 when the camera changed, 0 when not, -1
 * out of memory. */
int rt_scene_fit_film(rt_scene *s, int W, int H, rt_err *e);
#endif
