/*
 * scene_load.c -- a scene from its spec (prefix rt_scene_load): the one place
 * that knows every loader. It sits above them -- scene_builtin.c,
 * scene_obj.c, scene_ply.c, scene_pbrt.c -- which build scenes through the
 * container (scene.c, scene.h) and know nothing of each other or of this
 * dispatch, so no include runs in a circle.
 */
#include "config.h"
#include "scene_load.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int has_suffix(const char *s, const char *suf)
{
    size_t n = strlen(s), m = strlen(suf);
    if (n < m) return 0;
    for (size_t i = 0; i < m; i++) {
        char a = s[n - m + i], b = suf[i];
        if (a >= 'A' && a <= 'Z') a = (char)(a - 'A' + 'a');
        if (a != b) return 0;
    }
    return 1;
}

/* The suffix of a scene file's name: ".obj", ".ply" or ".pbrt", each
 * also with ".gz" after it (the loaders tell gzip by content, so a
 * gzipped file under the plain name loads too). */
static int has_type(const char *s, const char *suf)
{
    size_t n = strlen(s);
    if (has_suffix(s, suf)) return 1;
    if (n < 3 || !has_suffix(s, ".gz")) return 0;
    char tmp[16];
    size_t m = strlen(suf);
    if (n < 3 + m || m + 1 > sizeof tmp) return 0;
    memcpy(tmp, s + n - 3 - m, m);
    tmp[m] = 0;
    return has_suffix(tmp, suf);
}

/* A spec (or its part before the parameters) naming a scene file. */
static int is_file(const char *s) { return has_type(s, ".obj") || has_type(s, ".ply") || has_type(s, ".pbrt"); }

/* Loads a spec without its material=PRESET item. */
static rt_scene *load_base(const char *spec, const char *params, unsigned flags, rt_err *e)
{
    char name[64];
    size_t fn = strlen(spec);
    if (has_type(spec, ".pbrt")) return rt_scene_load_pbrt_flags(spec, params, flags, e);
    if (has_type(spec, ".obj") || has_type(spec, ".ply")) {
        if (params[0]) {
            rt_errf(e, "%s: unknown parameter '%s' (known for mesh files: material)", spec, params);
            return NULL;
        }
        return has_type(spec, ".obj") ? rt_scene_load_obj(spec, e) : rt_scene_load_ply(spec, e);
    }
    if (fn >= sizeof name) {
        rt_errf(e, "unknown scene '%.40s...' (not .obj/.ply/.pbrt, not a built-in; see 'raytraffic scene list')", spec);
        return NULL;
    }
    memcpy(name, spec, fn);
    name[fn] = 0;
    return rt_scene_builtin(name, params, e);
}

rt_scene *rt_scene_load(const char *spec, rt_err *e) { return rt_scene_load_flags(spec, 0, e); }

rt_scene *rt_scene_load_flags(const char *spec, unsigned flags, rt_err *e)
{
    if (!spec || !*spec) {
        rt_errf(e, "empty scene spec");
        return NULL;
    }
    /* Split "base:params". A scene file is a spec ending in .obj/.ply/.pbrt,
     * or one whose last ':' follows such a suffix; a built-in's name ends at
     * the first ':'. */
    size_t n = strlen(spec), fn = n;
    int file = is_file(spec);
    if (!file)
        for (size_t i = n; i-- > 4;)
            if (spec[i] == ':') {
                char suf[9];
                size_t k = i < 8 ? i : 8;
                memcpy(suf, spec + i - k, k);
                suf[k] = 0;
                if (is_file(suf)) {
                    file = 1;
                    fn = i;
                }
                break;
            }
    if (!file) {
        const char *colon = strchr(spec, ':');
        if (colon) fn = (size_t)(colon - spec);
    }
    char *base = rt_calloc(n + 1, 1, e), *rest = rt_calloc(n + 1, 1, e);
    rt_scene *s = NULL;
    if (!base || !rest) goto done;
    memcpy(base, spec, fn);
    /* Take material=NAME out of the parameters; pass the rest on. */
    const char *mat = NULL;
    size_t matlen = 0, nr = 0;
    const char *p = fn < n ? spec + fn + 1 : spec + n;
    int first = 1;
    while (fn < n) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len >= 9 && !memcmp(p, "material=", 9)) {
            if (mat) {
                rt_errf(e, "%s: parameter 'material' given twice", base);
                goto done;
            }
            mat = p + 9;
            matlen = len - 9;
        } else {
            if (!first) rest[nr++] = ',';
            memcpy(rest + nr, p, len);
            nr += len;
            first = 0;
        }
        if (!end) break;
        p = end + 1;
    }
    rest[nr] = 0;
    char preset[16];
    if (mat) {
        if (matlen == 0 || matlen >= sizeof preset) {
            char q[48];
            rt_errf(e, "%s: unknown material '%s' (known: diffuse, mirror, glass)", base,
                    rt_esc(q, sizeof q, mat, matlen));
            goto done;
        }
        memcpy(preset, mat, matlen);
        preset[matlen] = 0;
    }
    s = load_base(base, rest, flags, e);
    if (s && mat) {
        if (rt_scene_set_material(s, preset, e) < 0) {
            rt_scene_free(s);
            s = NULL;
            goto done;
        }
        size_t k = strlen(s->params);
        snprintf(s->params + k, sizeof s->params - k, "%smaterial=%s", k ? "," : "", preset);
    }
done:
    free(base);
    free(rest);
    return s;
}
