/*
 * test_options.c -- the render option table (tracegen/options.h):
 * its checker passes on the table and fails on each corrupted copy; every
 * entry's example value parses; every numeric value refuses hex, white
 * space, '+', overflow and nan; every entry with a run-key spelling puts
 * "KEY=" in the run key of a tracer that reads it; --lights refuses an
 * index --light did not define.
 */
#include "check.h"
#include "accel.h"
#include "options.h"
#include "scene_load.h"
#include "run.h"
#include "tracer.h"

#include <limits.h>

/* A tracer reading the entry's group (the reference one for group 0). */
static const rt_tracer *reader(const rt_render_optdef *d)
{
    if (!d->group) return rt_tracer_reference();
    for (int i = 0; rt_tracer_all[i]; i++)
        if (rt_tracer_all[i]->opts & d->group) return rt_tracer_all[i];
    return NULL;
}

static void checker(void)
{
    rt_err e = {0};
    CHECK(rt_render_optdefs_check(&e) == 0, "the table: %s", e.msg);
    int n = rt_render_noptdefs;
    CHECK(n >= 30 && n <= 64, "%d entries", n);
    rt_render_optdef *t = malloc((size_t)n * sizeof *t);
    if (!t) return;
    static const struct {
        int inv;
        const char *what;
    } cases[] = {{1, "a name twice"}, {1, "a name without --"}, {2, "a short name twice"},
                 {3, "no parser"},    {5, "no example"},        {5, "empty help"}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        memcpy(t, rt_render_optdefs, (size_t)n * sizeof *t);
        int i = rt_render_opt_find("--qorder"), j = rt_render_opt_find("--threads");
        switch (k) {
        case 0: t[j].name = t[i].name; break;
        case 1: t[j].name = "threads"; break;
        case 2: t[j].short_name = 'W'; break;
        case 3: t[j].parse = NULL; break;
        case 4: t[j].example = NULL; break;
        case 5: t[j].help = ""; break;
        }
        char want[8];
        snprintf(want, sizeof want, "(%d)", cases[k].inv);
        memset(&e, 0, sizeof e);
        CHECK(rt_render_optdefs_check_table(t, n, &e) < 0 && strstr(e.msg, want), "%s passes: '%s'", cases[k].what, e.msg);
    }
    memcpy(t, rt_render_optdefs, (size_t)n * sizeof *t);
    CHECK(rt_render_optdefs_check_table(t, n, &e) == 0, "the copy: %s", e.msg);
    CHECK(rt_render_optdefs_check_table(t, 65, &e) < 0 && strstr(e.msg, "(4)"), "65 entries pass");
    free(t);
    CHECK(rt_render_opt_find("--packet") >= 0 && rt_render_opt_find("packet") == rt_render_opt_find("--packet") &&
              rt_render_opt_find("--no-such") < 0 && !strcmp(rt_render_opt_name(rt_render_opt_find("gmax")), "--gmax"),
          "find");
}

/* Every example parses and changes the options. */
static void examples(void)
{
    rt_render_opts d;
    rt_render_default_opts(&d);
    for (int i = 0; i < rt_render_noptdefs; i++) {
        const rt_render_optdef *x = &rt_render_optdefs[i];
        if (!x->parse || !x->help) continue;
        rt_render_opts o = d;
        rt_err e = {0};
        CHECK(x->parse(&o, x->example, &e) >= 0, "%s %s: %s", x->name, x->example ? x->example : "", e.msg);
        CHECK(memcmp(&o, &d, sizeof o) != 0, "%s %s changed nothing", x->name, x->example ? x->example : "");
    }
}

/* The strict rule: the bad word in place of the example's first field
 * (comma- or colon-separated) is refused, with a message naming the
 * option. */
static void strict_numbers(void)
{
    static const char *const bad[] = {"0x10", " 1", "+2", "1e999", "nan", "inf", "", "1 ", "2x"};
    int numeric = 0;
    for (int i = 0; i < rt_render_noptdefs; i++) {
        const rt_render_optdef *x = &rt_render_optdefs[i];
        if (!x->parse || !x->example || !(x->example[0] >= '0' && x->example[0] <= '9')) continue;
        numeric++;
        const char *rest = x->example + strcspn(x->example, ",:");
        for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
            char arg[128];
            snprintf(arg, sizeof arg, "%s%s", bad[k], rest);
            rt_render_opts o;
            rt_render_default_opts(&o);
            rt_err e = {0};
            CHECK(x->parse(&o, arg, &e) < 0 && strstr(e.msg, x->short_name ? (char[]){'-', (char)x->short_name, 0} : x->name),
                  "%s '%s' accepted or unnamed: '%s'", x->name, arg, e.msg);
        }
    }
    CHECK(numeric >= 18, "%d numeric options", numeric);
    /* the strict parsers themselves */
    long l;
    double v;
    CHECK(rt_opt_parse_long("16", 0, 100, &l) == 0 && l == 16 && rt_opt_parse_long("-3", -5, 5, &l) == 0 && l == -3,
          "plain integers");
    CHECK(rt_opt_parse_long("0x10", 0, 100, &l) < 0 && rt_opt_parse_long("+2", 0, 100, &l) < 0 &&
              rt_opt_parse_long("101", 0, 100, &l) < 0 && rt_opt_parse_long("99999999999999999999", 0, LONG_MAX, &l) < 0,
          "lenient integers");
    CHECK(rt_opt_parse_double("0.25", &v) == 0 && v == 0.25 && rt_opt_parse_double("-1e3", &v) == 0 && v == -1000 &&
              rt_opt_parse_double(".5", &v) == 0 && v == 0.5,
          "plain numbers");
    CHECK(rt_opt_parse_double("0x1p0", &v) < 0 && rt_opt_parse_double("1e999", &v) < 0 && rt_opt_parse_double("nan", &v) < 0 &&
              rt_opt_parse_double("+1", &v) < 0 && rt_opt_parse_double(" 1", &v) < 0,
          "lenient numbers");
}

/* The entry's run-key spelling is what the run key holds. */
static void run_keys(void)
{
    static const int modes[] = {RT_MODE_DEFAULT, RT_MODE_WHITTED, RT_MODE_PATH};
    for (int i = 0; i < rt_render_noptdefs; i++) {
        const rt_render_optdef *x = &rt_render_optdefs[i];
        if (!x->key) continue;
        const rt_tracer *tr = reader(x);
        CHECK(tr != NULL, "%s: no tracer reads group %#x", x->name, x->group);
        if (!tr) continue;
        char want[64], buf[1024];
        snprintf(want, sizeof want, "%s=", x->key);
        int found = 0;
        for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++) {
            rt_render_opts o;
            rt_render_default_opts(&o);
            o.mode = modes[m];
            rt_err e = {0};
            if (x->parse(&o, x->example, &e) < 0) continue;
            rt_job_params(tr->name, &o, NULL, buf, sizeof buf);
            found |= strstr(buf, want) != NULL;
        }
        CHECK(found, "%s %s: no '%s' in the %s tracer's run key ('%s')", x->name, x->example ? x->example : "", want,
              tr->name, buf);
    }
}

static void lights(void)
{
    int li = rt_render_opt_find("--lights"), l1 = rt_render_opt_find("--light");
    rt_render_opts o;
    rt_render_default_opts(&o);
    rt_err e = {0};
    CHECK(rt_render_optdefs[l1].parse(&o, "0.5,0.5,0.9", &e) == 0, "--light: %s", e.msg);
    CHECK(rt_render_optdefs[li].parse(&o, "1,2", &e) == 0 && o.lights == 6, "--lights 1,2");
    CHECK(rt_render_check_lights(&o, &e) < 0 && e.usage && strstr(e.msg, "light 1 is not defined"), "'%s'", e.msg);
    CHECK(rt_render_optdefs[li].parse(&o, "0", &e) == 0 && rt_render_check_lights(&o, &e) == 0, "--lights 0: %s", e.msg);
    CHECK(rt_render_optdefs[li].parse(&o, "all", &e) == 0 && rt_render_check_lights(&o, &e) == 0, "--lights all: %s",
          e.msg);
    CHECK(rt_render_optdefs[l1].parse(&o, "0.2,0.5,0.9", &e) == 0 && rt_render_optdefs[li].parse(&o, "0,1", &e) == 0 &&
              rt_render_check_lights(&o, &e) == 0,
          "two lights, --lights 0,1: %s", e.msg);
    CHECK(rt_render_optdefs[li].parse(&o, "2", &e) == 0 && rt_render_check_lights(&o, &e) < 0 && strstr(e.msg, "light 2"),
          "two lights, --lights 2: '%s'", e.msg);
    rt_render_default_opts(&o); /* without --light the scene's three exist */
    CHECK(rt_render_optdefs[li].parse(&o, "2", &e) == 0 && rt_render_check_lights(&o, &e) == 0, "scene lights: %s", e.msg);
}

/* The accel layer's lists: masks from names, BVH widths, surveys. */
static void accel_lists(void)
{
    rt_err e = {0};
    unsigned m = 0;
    CHECK(rt_accel_parse_mask("kd,bvh4", &m, &e) == 0 && m == (RT_ACCEL_BIT(RT_ACCEL_KD) | RT_ACCEL_BIT(RT_ACCEL_BVH4)),
          "kd,bvh4: %#x %s", m, e.msg);
    CHECK(rt_accel_parse_mask("all", &m, &e) == 0 && m == 0x7e, "all: %#x", m);
    CHECK(rt_accel_parse_mask("none", &m, &e) == 0 && m == 0, "none: %#x", m);
    CHECK(rt_accel_parse_mask("kd,", &m, &e) < 0 && rt_accel_parse_mask("kd,nope", &m, &e) < 0 && strstr(e.msg, "nope") &&
              rt_accel_parse_mask("", &m, &e) < 0 && rt_accel_parse_mask("default", &m, &e) < 0,
          "bad lists accepted");
    /* widths against the names ("bvhN"), a naive reference */
    for (int k = 0; k <= RT_ACCEL_NKINDS; k++) {
        const char *n = rt_accel_name(k);
        int w = n && !strncmp(n, "bvh", 3) ? atoi(n + 3) : 0;
        CHECK(rt_accel_bvh_width(k) == w, "kind %d (%s): width %d, the name says %d", k, n ? n : "-", rt_accel_bvh_width(k), w);
    }
    rt_scene *sc = rt_scene_load("cornell:glass=0", &e);
    CHECK(sc != NULL, "%s", e.msg);
    if (!sc) return;
    rt_accel_survey_row rows[RT_ACCEL_NKINDS];
    int n = rt_accel_survey(sc, RT_ACCEL_BIT(RT_ACCEL_BVH8) | RT_ACCEL_BIT(RT_ACCEL_KD), NULL, rows, &e);
    CHECK(n == 2 && rows[0].kind == RT_ACCEL_KD && rows[1].kind == RT_ACCEL_BVH8 && rows[0].has_kd && !rows[1].has_kd,
          "survey of kd and bvh8: %d rows, %s", n, e.msg);
    /* cornell:glass=0's k-d tree (tests/render_cli.sh): 75 nodes, 38 leaves, 222 entries */
    CHECK(n == 2 && rows[0].info.nodes == 75 && rows[0].kd_leaves == 38 && rows[0].kd_entries == 222 &&
              rows[0].info.bytes == 8 * 75 + 4 * 222,
          "kd row: %llu nodes %u leaves %u entries", (unsigned long long)rows[0].info.nodes, rows[0].kd_leaves,
          rows[0].kd_entries);
    for (int j = 0; j < n; j++) {
        rt_accel a;
        rt_accel_info inf;
        CHECK(rt_accel_build(&a, rows[j].kind, sc, NULL, &e) == 0, "%s", e.msg);
        rt_accel_info_of(&a, &inf);
        CHECK(inf.nodes == rows[j].info.nodes && inf.bytes == rows[j].info.bytes && inf.depth == rows[j].info.depth,
              "%s: the survey's footprint differs from a build's", rt_accel_name(rows[j].kind));
        rt_accel_free(&a);
    }
    CHECK(rt_accel_survey(sc, 0, NULL, rows, &e) == 0, "an empty mask builds something");
    rt_scene_free(sc);
}

int main(void)
{
    accel_lists();
    checker();
    examples();
    strict_numbers();
    run_keys();
    lights();
    return failures ? 1 : 0;
}
