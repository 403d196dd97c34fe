/*
 * cmd_scene.c -- `raytraffic scene`: list the built-in scenes, describe a
 * scene (triangles, bounds, identity hash, camera, lights and the statistics
 * of its SAH k-d tree; the build time and footprint of the acceleration
 * structures asked for, built by the accel layer: rt_accel_survey), and
 * export a scene as OBJ.
 *
 *   raytraffic scene list
 *   raytraffic scene info SCENE [--json] [--no-tree] [--accel LIST]
 *   raytraffic scene export SCENE -o FILE.obj
 */
#include "config.h"
#include "accel.h"
#include "alpha.h"
#include "cmd.h"
#include "scene.h"
#include "scene_load.h"

#include <inttypes.h>
#include <stdio.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: raytraffic scene list\n"
            "       raytraffic scene info SCENE [--json] [--no-tree] [--accel LIST] [--strict] [VIEW]\n"
            "       raytraffic scene export SCENE -o FILE.obj [VIEW]\n\n"
            "SCENE is a built-in name with optional parameters (sphereflake:level=2,tess=3)\n"
            "or a scene file ending in .obj, .ply or .pbrt.\n\n"
            "  list      built-in scenes, their parameters and one-line descriptions\n"
            "  info      triangles, bounds, scene hash, camera, lights and k-d tree statistics\n"
            "            and per acceleration structure built its build time, nodes,\n"
            "            modeled bytes (nodes and index lists) and depth\n"
            "            --json     one JSON object on stdout (warnings included)\n"
            "            --strict   refuse a scene whose loading warned\n"
            "            --accel LIST  the structures to build: a comma list of\n"
            "                       %s, or all, or none\n"
            "                       (default %s, the default structure)\n"
            "            --no-tree  build no structure (same as --accel none)\n"
            "  export    write the scene's triangles as Wavefront OBJ\n"
            "            -o FILE    output file (required)\n\n"
            "VIEW replaces the scene's camera and lights, as for render:\n"
            "  --look-at EX,EY,EZ,AX,AY,AZ[,UX,UY,UZ]   --fov DEGREES   --light X,Y,Z[,POWER] (up to 3)\n",
            rt_accel_names(), rt_accel_name(rt_tracer_reference()->accel_default));
}

static int cmd_list(int argc, char **argv)
{
    if (rt_cmd_wants_help(argc, argv)) {
        usage(stdout);
        return RT_EXIT_OK;
    }
    if (argc > 1) {
        rt_cmd_error("scene", "list takes no arguments (got '%s')", argv[1]);
        return RT_EXIT_USAGE;
    }
    for (int i = 0; rt_scene_builtin_names[i]; i++) {
        const char *n = rt_scene_builtin_names[i];
        char pbuf[512];
        printf("%-12s %s\n", n, rt_scene_describe(n));
        if (rt_scene_builtin_params(n, pbuf, sizeof pbuf) == 0 && pbuf[0])
            printf("%-12s   params: %s\n", "", pbuf);
    }
    printf("%-12s %s\n", "FILE.obj", "Wavefront OBJ mesh (auto-framed camera, default lights)");
    printf("%-12s %s\n", "FILE.ply", "Stanford PLY mesh, ascii or binary (auto-framed camera, default lights)");
    printf("%-12s %s\n", "FILE.pbrt", "pbrt-v4 scene, geometry and view (params tess=3, maxtri=67108864)");
    return RT_EXIT_OK;
}

/* Prints s as a JSON string (escaping quotes, backslashes, controls). */
static void json_str(const char *s) { rt_cmd_json_str(stdout, s); }

static void json_vec(const char *key, rt_vec3 v, int comma)
{
    printf("  \"%s\": [%.9g, %.9g, %.9g]%s\n", key, (double)v.x, (double)v.y, (double)v.z, comma ? "," : "");
}

/* --look-at, --fov and --light (value in the next word): 1 taken (*i
 * advanced), 0 not one of them, -1 usage error (printed). */
static int view_opt(int argc, char **argv, int *i, rt_render_opts *o)
{
    static const char *const vo[] = {"--look-at", "--fov", "--light"};
    for (size_t k = 0; k < sizeof vo / sizeof vo[0]; k++) {
        if (strcmp(argv[*i], vo[k])) continue;
        if (*i + 1 >= argc) {
            rt_cmd_error("scene", "%s needs a value", vo[k]);
            return -1;
        }
        if (rt_cmd_render_opt_named("scene", vo[k], argv[++*i], o) < 0) return -1;
        return 1;
    }
    return 0;
}

/* Loads spec with the user's view applied; NULL (printed) on failure. */
static rt_scene *load_viewed(const char *spec, const rt_render_opts *o)
{
    rt_err e = {0};
    rt_scene *s = rt_scene_load(spec, &e);
    if (s && rt_render_apply_view(o, s, &e) < 0) {
        rt_scene_free(s);
        s = NULL;
    }
    if (!s) rt_cmd_error("scene", "%s", e.msg);
    return s;
}

static int cmd_info(int argc, char **argv)
{
    if (rt_cmd_wants_help(argc, argv)) {
        usage(stdout);
        return RT_EXIT_OK;
    }
    const char *spec = NULL;
    rt_err e = {0};
    int json = 0, strict = 0, v;
    /* the default: the reference tracer's structure; --accel LIST, all or none */
    unsigned mask = RT_ACCEL_BIT(rt_tracer_reference()->accel_default);
    rt_render_opts vo;
    rt_render_default_opts(&vo);
    for (int i = 1; i < argc; i++) {
        if ((v = view_opt(argc, argv, &i, &vo)) != 0) {
            if (v < 0) return RT_EXIT_USAGE;
        } else if (!strcmp(argv[i], "--json")) json = 1;
        else if (!strcmp(argv[i], "--strict")) strict = 1;
        else if (!strcmp(argv[i], "--accel")) {
            if (i + 1 >= argc) {
                rt_cmd_error("scene", "info: --accel needs a structure (%s)", rt_accel_names());
                return RT_EXIT_USAGE;
            }
            if (rt_accel_parse_mask(argv[++i], &mask, &e) < 0) {
                rt_cmd_error("scene", "info: --accel: %s", e.msg);
                return RT_EXIT_USAGE;
            }
        }
        else if (!strcmp(argv[i], "--no-tree")) mask = 0;
        else if (argv[i][0] == '-' && argv[i][1]) {
            rt_cmd_error("scene", "info: unknown option '%s'", argv[i]);
            return RT_EXIT_USAGE;
        } else if (spec) {
            rt_cmd_error("scene", "info: more than one scene given ('%s', '%s')", spec, argv[i]);
            return RT_EXIT_USAGE;
        } else spec = argv[i];
    }
    if (!spec) {
        rt_cmd_error("scene", "info: no scene given (see 'raytraffic scene --help')");
        return RT_EXIT_USAGE;
    }
    double t0 = rt_now();
    rt_scene *s = load_viewed(spec, &vo);
    if (!s) return RT_EXIT_FAIL;
    double load_sec = rt_now() - t0;
    if (strict && rt_cmd_strict("scene", s) < 0) {
        rt_scene_free(s);
        return RT_EXIT_FAIL;
    }
    if (!json) rt_cmd_print_warnings("scene", s); /* --json: in the object */
    /* the structures asked for, built by the accel layer one at a time */
    rt_accel_survey_row inf[RT_ACCEL_NKINDS];
    int nacc = rt_accel_survey(s, mask, NULL, inf, &e);
    if (nacc < 0) {
        rt_cmd_error("scene", "%s: %s", spec, e.msg);
        rt_scene_free(s);
        return RT_EXIT_FAIL;
    }
    const rt_accel_survey_row *kd = NULL;
    for (int j = 0; j < nacc; j++)
        if (inf[j].has_kd) kd = &inf[j];
    uint64_t h = rt_scene_hash(s);
    if (json) {
        printf("{\n  \"spec\": ");
        json_str(spec);
        printf(",\n  \"name\": ");
        json_str(s->name);
        printf(",\n  \"params\": ");
        json_str(s->params);
        printf(",\n  \"triangles\": %u,\n", s->ntri);
        if (s->alpha) {
            uint32_t cut = 0;
            for (uint32_t t = 0; t < s->alpha->nrec; t++) cut += s->alpha->tmap[t] != 0;
            printf("  \"alpha_textures\": %u,\n  \"alpha_texels\": %" PRIu64 ",\n  \"alpha_triangles\": %u,\n",
                   s->alpha->nmap, s->alpha->ntexel, cut);
        }
        if (s->ninst)
            printf("  \"instances\": %u,\n  \"triangles_unique\": %u,\n  \"triangles_instanced\": %u,\n", s->ninst,
                   s->ntri_unique, s->ntri_inst);
        if (s->nirec) /* what --instances bvh builds its two levels from */
            printf("  \"instance_records\": %u,\n", s->nirec);
        if (s->film_w) printf("  \"film\": [%d, %d],\n", s->film_w, s->film_h);
        printf("  \"hash\": \"%016" PRIx64 "\",\n", h);
        json_vec("bounds_lo", s->bounds.lo, 1);
        json_vec("bounds_hi", s->bounds.hi, 1);
        json_vec("eye", s->cam.eye, 1);
        json_vec("at", s->cam.at, 1);
        json_vec("up", s->cam.up, 1);
        printf("  \"fovy_deg\": %.9g,\n", (double)s->cam.fovy_deg);
        printf("  \"lights\": [");
        for (int i = 0; i < RT_NLIGHTS; i++)
            printf("%s[%.9g, %.9g, %.9g]", i ? ", " : "", (double)s->light[i].x, (double)s->light[i].y,
                   (double)s->light[i].z);
        printf("],\n");
        if (s->nlight) { /* the file's own lights (--light-samples), only when it has some */
            printf("  \"file_lights\": [");
            for (uint32_t i = 0; i < s->nlight; i++) {
                const rt_light *l = &s->lights[i];
                printf("%s\n    {\"kind\": \"%s\", \"p\": [%.9g, %.9g, %.9g], \"d\": [%.9g, %.9g, %.9g], \"r\": %.9g, "
                       "\"triangles\": %u, \"at\": ",
                       i ? "," : "", rt_light_kind_name(l->kind), (double)l->p.x, (double)l->p.y, (double)l->p.z,
                       (double)l->d.x, (double)l->d.y, (double)l->d.z, (double)l->r, l->count);
                rt_cmd_json_str(stdout, l->at);
                printf("}");
            }
            printf("\n  ],\n");
        }
        printf("  \"light_power\": %.9g,\n  \"ambient\": %.9g,\n", (double)s->light_power, (double)s->ambient);
        printf("  ");
        rt_cmd_json_warnings(stdout, s);
        printf(",\n  \"load_sec\": %.6f", load_sec);
        if (kd) {
            printf(",\n  \"kd\": {\"nodes\": %u, \"leaves\": %u, \"empty_leaves\": %u, \"depth\": %u, "
                   "\"index_entries\": %u, \"mean_leaf_tris\": %.4f, \"max_leaf_tris\": %u, \"build_sec\": %.6f}",
                   (unsigned)kd->info.nodes, kd->kd_leaves, kd->kd_empty, kd->info.depth, kd->kd_entries,
                   kd->kd_mean_leaf, kd->kd_max_leaf, kd->build_sec);
        }
        if (nacc) {
            printf(",\n  \"accel\": [");
            for (int j = 0; j < nacc; j++)
                printf("%s\n    {\"name\": \"%s\", \"build_sec\": %.6f, \"nodes\": %" PRIu64 ", \"bytes\": %" PRIu64
                       ", \"depth\": %u}",
                       j ? "," : "", rt_accel_name(inf[j].kind), inf[j].build_sec, inf[j].info.nodes, inf[j].info.bytes,
                       inf[j].info.depth);
            printf("\n  ]");
        }
        printf("\n}\n");
    } else {
        printf("scene        %s%s%s\n", s->name, s->params[0] ? ":" : "", s->params);
        printf("triangles    %u\n", s->ntri);
        if (s->ninst)
            printf("instancing   %u unique triangles; %u instances give %u of the total\n", s->ntri_unique, s->ninst,
                   s->ntri_inst);
        if (s->nirec)
            printf("two-level    %u instance records (objects of 3 or more triangles; --instances bvh)\n", s->nirec);
        if (s->alpha) {
            uint32_t cut = 0;
            for (uint32_t t = 0; t < s->alpha->nrec; t++) cut += s->alpha->tmap[t] != 0;
            printf("alpha        %u texture%s (%" PRIu64 " texels), %u triangles with a cutout\n", s->alpha->nmap,
                   s->alpha->nmap == 1 ? "" : "s", s->alpha->ntexel, cut);
        }
        if (s->film_w) printf("film         %dx%d (the default image size)\n", s->film_w, s->film_h);
        printf("hash         %016" PRIx64 "\n", h);
        printf("bounds       (%.6g, %.6g, %.6g) - (%.6g, %.6g, %.6g)\n", (double)s->bounds.lo.x,
               (double)s->bounds.lo.y, (double)s->bounds.lo.z, (double)s->bounds.hi.x, (double)s->bounds.hi.y,
               (double)s->bounds.hi.z);
        printf("camera       eye (%.6g, %.6g, %.6g) at (%.6g, %.6g, %.6g) up (%.6g, %.6g, %.6g) fovy %.6g\n",
               (double)s->cam.eye.x, (double)s->cam.eye.y, (double)s->cam.eye.z, (double)s->cam.at.x,
               (double)s->cam.at.y, (double)s->cam.at.z, (double)s->cam.up.x, (double)s->cam.up.y,
               (double)s->cam.up.z, (double)s->cam.fovy_deg);
        for (int i = 0; i < RT_NLIGHTS; i++)
            printf("light %d      (%.6g, %.6g, %.6g)\n", i, (double)s->light[i].x, (double)s->light[i].y,
                   (double)s->light[i].z);
        for (uint32_t i = 0; i < s->nlight; i++) { /* the file's own lights (--light-samples) */
            const rt_light *l = &s->lights[i];
            printf("file light %-2u %-8s", i, rt_light_kind_name(l->kind));
            if (l->kind == RT_LIGHT_MESH) printf(" triangles %u..%u", l->first, l->first + l->count - 1);
            else if (l->kind == RT_LIGHT_POINT || l->kind == RT_LIGHT_SPHERE || l->kind == RT_LIGHT_DISK)
                printf(" (%.6g, %.6g, %.6g)", (double)l->p.x, (double)l->p.y, (double)l->p.z);
            if (l->kind == RT_LIGHT_DISTANT || l->kind == RT_LIGHT_DISK)
                printf(" %s (%.6g, %.6g, %.6g)", l->kind == RT_LIGHT_DISK ? "normal" : "toward", (double)l->d.x,
                       (double)l->d.y, (double)l->d.z);
            if (l->kind == RT_LIGHT_SPHERE || l->kind == RT_LIGHT_DISK) printf(" radius %.6g", (double)l->r);
            printf("  %s\n", l->at);
        }
        printf("shading      light_power %.6g, ambient %.6g\n", (double)s->light_power, (double)s->ambient);
        if (s->nmat > 1) rt_scene_describe_materials(s, stdout);
        printf("load time    %.3f s\n", load_sec);
        if (kd) {
            printf("kd nodes     %u\n", (unsigned)kd->info.nodes);
            printf("kd leaves    %u (%u empty)\n", kd->kd_leaves, kd->kd_empty);
            printf("kd depth     %u\n", kd->info.depth);
            printf("kd entries   %u\n", kd->kd_entries);
            printf("kd leaf tris mean %.2f (non-empty leaves), max %u\n", kd->kd_mean_leaf, kd->kd_max_leaf);
            printf("kd build     %.3f s\n", kd->build_sec);
        }
        if (nacc) printf("structure    build s        nodes          bytes  depth\n");
        for (int j = 0; j < nacc; j++)
            printf("  %-8s %9.3f %12" PRIu64 " %14" PRIu64 " %6u\n", rt_accel_name(inf[j].kind), inf[j].build_sec,
                   inf[j].info.nodes, inf[j].info.bytes, inf[j].info.depth);
    }
    rt_scene_free(s);
    return RT_EXIT_OK;
}

static int cmd_export(int argc, char **argv)
{
    if (rt_cmd_wants_help(argc, argv)) {
        usage(stdout);
        return RT_EXIT_OK;
    }
    const char *spec = NULL, *out = NULL;
    rt_render_opts vo;
    rt_render_default_opts(&vo);
    int v;
    for (int i = 1; i < argc; i++) {
        if ((v = view_opt(argc, argv, &i, &vo)) != 0) {
            if (v < 0) return RT_EXIT_USAGE;
            continue;
        }
        if (!strcmp(argv[i], "-o") || !strcmp(argv[i], "--output")) {
            if (i + 1 >= argc) {
                rt_cmd_error("scene", "export: %s needs a file name", argv[i]);
                return RT_EXIT_USAGE;
            }
            out = argv[++i];
            if (!*out) {
                rt_cmd_error("scene", "export: %s: empty file name", argv[i - 1]);
                return RT_EXIT_USAGE;
            }
        } else if (argv[i][0] == '-' && argv[i][1]) {
            rt_cmd_error("scene", "export: unknown option '%s'", argv[i]);
            return RT_EXIT_USAGE;
        } else if (spec) {
            rt_cmd_error("scene", "export: more than one scene given ('%s', '%s')", spec, argv[i]);
            return RT_EXIT_USAGE;
        } else spec = argv[i];
    }
    if (!spec || !out) {
        rt_cmd_error("scene", "export: need a scene and -o FILE.obj");
        return RT_EXIT_USAGE;
    }
    rt_err e = {0};
    rt_scene *s = load_viewed(spec, &vo);
    if (!s) return RT_EXIT_FAIL;
    int rc = rt_scene_export_obj(s, out, &e);
    rt_scene_free(s);
    if (rc < 0) {
        rt_cmd_error("scene", "%s", e.msg);
        return RT_EXIT_FAIL;
    }
    return RT_EXIT_OK;
}

int main_scene(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return RT_EXIT_OK;
    }
    const char *sub = argv[1];
    if (!strcmp(sub, "list")) return cmd_list(argc - 1, argv + 1);
    if (!strcmp(sub, "info")) return cmd_info(argc - 1, argv + 1);
    if (!strcmp(sub, "export")) return cmd_export(argc - 1, argv + 1);
    rt_cmd_error("scene", "unknown subcommand '%s' (list, info, export)", sub);
    return RT_EXIT_USAGE;
}
