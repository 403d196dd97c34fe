/*
 * scene_ply.c -- the PLY loader: a scene from a Stanford PLY file, read by
 * the shared reader (ply_read.c, which has the format and its errors).
 * PLY carries no materials: every triangle gets the default grey and the
 * plain material (a spec's material=PRESET can change that).
 */
#include "config.h"
#include "scene.h"
#include "scene_load.h"
#include "ply_read.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static rt_scene *build(const char *path, const rt_ply_mesh *m, rt_err *e)
{
    const rt_vec3 *verts = m->v;
    if (m->nidx / 3 > UINT32_MAX / 2) return rt_errf(e, "%s: too many triangles", path), NULL;
    rt_scene *s = rt_scene_new((uint32_t)(m->nidx / 3), e);
    if (!s) return NULL;
    const char *base = strrchr(path, '/');
    snprintf(s->name, sizeof s->name, "%s", base ? base + 1 : path);
    for (size_t t = 0; t < m->nidx; t += 3)
        if (rt_scene_add_tri(s, verts[m->idx[t]], verts[m->idx[t + 1]], verts[m->idx[t + 2]], NULL, e) < 0)
            goto fail;
    if (rt_scene_finish(s, e) < 0) goto fail;
    if (rt_scene_check_range(s, path, e) < 0) goto fail;
    rt_scene_autoframe(s);
    return s;
fail:
    rt_scene_free(s);
    return NULL;
}

rt_scene *rt_scene_load_ply(const char *path, rt_err *e)
{
    rt_ply_mesh m;
    if (rt_ply_read_file(path, &m, e) < 0) return NULL;
    rt_scene *s = build(path, &m, e);
    rt_ply_mesh_free(&m);
    return s;
}
