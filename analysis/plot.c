/*
 * plot.c -- everything gnuplot: traffic against cache size per scene, the
 * speed-against-error scatter, and the scene thumbnails.
 *
 * No shell anywhere. Scene names come from the database and may be any
 * file name, so they never reach a command line: gnuplot runs with
 * fork/execvp on a script file (rt_plot_run), and every string written into
 * a script goes through rt_plot_quote, which escapes everything gnuplot
 * interprets inside a double-quoted string (backslash escapes, ` command
 * substitution) and keeps file names from being read as pipes ('<cmd',
 * '|cmd'). gnuplot's exit status is checked: a plot it cannot draw is an
 * error carrying the first line of its messages.
 *
 * Text: the terminals are enhanced only for the 10^{k} tick labels of log
 * axes; every title and key entry that comes from data is `noenhanced`, so
 * bun_zipper stays bun_zipper instead of growing a subscript. Ticks of log
 * axes are at powers of ten (a tic increment of 10 on a log axis is a
 * factor), and autoscaling extends the range to the next power, so an axis
 * always has at least two labelled ticks.
 */
#include "analysis_int.h"
#include "image.h"
#include "outfile.h"
#include "run.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "config.h"

/* ---- running gnuplot -------------------------------------------------------- */

static int executable(const char *path) { return access(path, X_OK) == 0; }

int rt_plot_find_gnuplot(char *buf, size_t n)
{
    const char *env = getenv("RT_GNUPLOT");
    if (env && *env) return snprintf(buf, n, "%s", env) < (int)n ? 0 : -1;
    if (GNUPLOT_PATH[0] && executable(GNUPLOT_PATH)) return snprintf(buf, n, "%s", GNUPLOT_PATH) < (int)n ? 0 : -1;
    const char *path = getenv("PATH");
    while (path && *path) {
        size_t len = strcspn(path, ":");
        if (len && snprintf(buf, n, "%.*s/gnuplot", (int)len, path) < (int)n && executable(buf)) return 0;
        path += len + (path[len] == ':');
    }
    return -1;
}

int rt_plot_run(const char *gnuplot, const char *script, rt_err *e)
{
    int fd[2];
    if (pipe(fd) < 0) return rt_errf(e, "%s: pipe: %s", script, strerror(errno));
    pid_t pid = fork();
    if (pid < 0) {
        close(fd[0]);
        close(fd[1]);
        return rt_errf(e, "%s: fork: %s", script, strerror(errno));
    }
    if (pid == 0) { /* child: stdout discarded, stderr into the pipe */
        int null = open("/dev/null", O_RDWR);
        if (null >= 0) {
            dup2(null, 0);
            dup2(null, 1);
        }
        dup2(fd[1], 2);
        close(fd[0]);
        /* a relative script path as ./PATH: "-dir/x.gp" must not be an option */
        char *arg = (char *)script;
        if (script[0] != '/' && !(arg = malloc(strlen(script) + 3))) _exit(127);
        if (arg != script) sprintf(arg, "./%s", script);
        char *const argv[] = {(char *)gnuplot, arg, NULL};
        execvp(gnuplot, argv);
        dprintf(2, "cannot run %s: %s\n", gnuplot, strerror(errno));
        _exit(127);
    }
    close(fd[1]);
    char msg[400];
    size_t len = 0;
    for (;;) { /* drain everything, keep the start */
        char chunk[4096];
        ssize_t r = read(fd[0], chunk, sizeof chunk);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        size_t take = (size_t)r < sizeof msg - 1 - len ? (size_t)r : sizeof msg - 1 - len;
        memcpy(msg + len, chunk, take);
        len += take;
    }
    close(fd[0]);
    msg[len] = 0;
    int status;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return rt_errf(e, "%s: waitpid: %s", script, strerror(errno));
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return 0;
    /* the first non-blank line of gnuplot's messages says what went wrong */
    char *line = msg + strspn(msg, " \t\r\n");
    line[strcspn(line, "\r\n")] = 0;
    if (WIFSIGNALED(status))
        return rt_errf(e, "%s: gnuplot killed by signal %d%s%s", script, WTERMSIG(status), *line ? ": " : "", line);
    return rt_errf(e, "%s: gnuplot exited with status %d%s%s", script, WEXITSTATUS(status), *line ? ": " : "", line);
}

/* ---- script strings ----------------------------------------------------------- */

int rt_plot_quote(FILE *f, const char *s)
{
    int rc = fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p && rc != EOF; p++) {
        if (*p >= 0x80 || (*p >= 0x20 && *p < 0x7f && !strchr("\"\\`@$", *p))) rc = fputc(*p, f);
        else rc = fprintf(f, "\\%03o", *p) < 0 ? EOF : 0;
    }
    if (rc != EOF) rc = fputc('"', f);
    return rc == EOF ? EOF : 0;
}

int rt_plot_quote_path(FILE *f, const char *path)
{
    if (path[0] == '/') return rt_plot_quote(f, path);
    char *buf = malloc(strlen(path) + 3);
    if (!buf) return EOF;
    sprintf(buf, "./%s", path);
    int rc = rt_plot_quote(f, buf);
    free(buf);
    return rc;
}

int rt_plot_mkdir(const char *dir, rt_err *e)
{
    if (mkdir(dir, 0777) < 0 && errno != EEXIST) return rt_errf(e, "%s: %s", dir, strerror(errno));
    return 0;
}

void rt_plot_path(char *buf, size_t n, const char *dir, const char *prefix, const char *name, const char *suffix)
{
    char fit[RT_PLOT_NAME_MAX + 1];
    rt_name_fit(fit, sizeof fit, name);
    for (char *q = fit; *q; q++)
        if (*q == '/') *q = '_';
    snprintf(buf, n, "%s/%s%s%s", dir, prefix, fit, suffix);
}

FILE *rt_plot_open(const char *path, rt_out **o, rt_err *e)
{
    *o = rt_out_open(path, e);
    return *o ? rt_out_stream(*o) : NULL;
}

int rt_plot_commit(rt_out *o, rt_err *e) { return rt_out_commit(o, e); }

int rt_plot_draw(const rt_plot_opts *p, const char *script, const char *const *outs, const char *what, rt_err *e)
{
    if (!p->gnuplot) return 0;
    if (rt_plot_run(p->gnuplot, script, e) < 0) return -1;
    for (int i = 0; outs && outs[i]; i++) {
        struct stat sb;
        if (stat(outs[i], &sb) < 0 || !S_ISREG(sb.st_mode) || sb.st_size == 0)
            return rt_errf(e, "%s: gnuplot wrote no picture %s", script, outs[i]);
    }
    if (p->log) fprintf(p->log, "wrote %s\n", what);
    return 0;
}

/* ---- traffic against cache size ------------------------------------------------- */

/* The x tics of a cache-size axis: every size of R, labelled "1K",
 * "64K", "1M" (powers of two, never 10^n). */
static void size_tics(FILE *f, const rt_report *R)
{
    fputs("set xtics (", f);
    for (int k = 0; k < R->nsizes; k++) {
        uint64_t kb = R->sizes[k] / 1024;
        if (kb >= 1024) fprintf(f, "%s\"%" PRIu64 "M\" %" PRIu64, k ? ", " : "", kb / 1024, kb);
        else fprintf(f, "%s\"%" PRIu64 "K\" %" PRIu64, k ? ", " : "", kb, kb);
    }
    fputs(")\nset xtics rotate by -45 font \",9\"\n", f);
}

/* The x range of a cache-size axis: a little beyond R's sizes. */
static void size_range(FILE *f, const rt_report *R)
{
    if (R->nsizes)
        fprintf(f, "set xrange [%.6g:%.6g]\n", (double)R->sizes[0] / 1024 / 1.25,
                (double)R->sizes[R->nsizes - 1] / 1024 * 1.25);
}

/* Columns of DIR/NAME-traffic.dat: 1 cache KB; 2-4 geometry MB of
 * recursive, packet, dynamic; 5-7 ray MB; 8-10 total MB; 11-16 the paper's
 * geometry and ray MB (NaN where it has none or the scene is not at its
 * setup); 17-19 the paper's totals; 20-21 recursive / dynamic of geometry
 * and total, ours; 22-23 the paper's. */
static int traffic_script(FILE *f, const rt_report *R, const char *scene, const char *dat, const char *base,
                          int paper, int mb)
{
    for (int t = 0; t < 2; t++) {
        char out[4200];
        snprintf(out, sizeof out, "%s.%s", base, t ? "svg" : "png");
        fprintf(f, "set terminal %s enhanced\nset output ",
                t ? "svg size 1200,900 dynamic font \"sans,11\"" : "pngcairo size 1200,900 font \"sans,11\"");
        rt_plot_quote_path(f, out);
        fprintf(f, "\nset multiplot layout 2,2 margins 0.08,0.97,0.16,0.90 spacing 0.08,0.13 title ");
        char title[512];
        snprintf(title, sizeof title, "%s: DRAM traffic, primary rays, %dx%d (fully associative, 64-byte lines)%s",
                 scene, R->W, R->H,
                 paper ? (mb ? "; dashed: the paper's values" : "; dashed: the paper's reductions (its MB are at "
                                                                "1024x1024)")
                       : "");
        rt_plot_quote(f, title);
        fprintf(f, " noenhanced\nset logscale xy\nset format y \"%%g\"\nset xlabel \"cache size\"\nset grid\n");
        size_tics(f, R);
        size_range(f, R);
        static const char *const what[3] = {"geometry", "ray", "total (geometry + ray)"};
        static const char *const col[3] = {"#0072b2", "#e69f00", "#009e73"};
        static const char *const name[3] = {"recursive", "packet", "dynamic"};
        static const int pt[3] = {7, 5, 9};
        for (int g = 0; g < 3; g++) {
            /* one key for the three traffic panels, below the page's left
             * half, outside every panel */
            if (g == 2) fprintf(f, "set key at screen 0.27,0.05 center horizontal maxrows 2 noenhanced\n");
            else fprintf(f, "unset key\n");
            fprintf(f, "set title \"%s traffic\"\nset ylabel \"MB\"\nplot ", what[g]);
            rt_plot_quote_path(f, dat);
            for (int k = 0; k < 3; k++)
                fprintf(f, "%s u 1:%d w lp lc rgb \"%s\" pt %d t \"%s\"", k ? ", ''" : "", 2 + 3 * g + k, col[k], pt[k],
                        name[k]);
            if (paper && mb)
                for (int k = 0; k < 3; k++)
                    fprintf(f, ", '' u 1:%d w lp dt 2 lc rgb \"%s\" pt %d t \"paper %s\"", 11 + 3 * g + k,
                            col[k], pt[k] - 1, name[k]);
            fputc('\n', f);
        }
        fprintf(f, "set key at screen 0.77,0.05 center horizontal maxrows 2 noenhanced\n"
                   "set title \"reduction: recursive / dynamic (above 1: dynamic moves less)\"\n"
                   "set ylabel \"recursive / dynamic\"\nplot ");
        rt_plot_quote_path(f, dat);
        fprintf(f, " u 1:20 w lp lc rgb \"#0072b2\" pt 7 t \"geometry\", '' u 1:21 w lp lc rgb \"#009e73\" pt 9 t "
                   "\"total\", 1 w l lc rgb \"#7f7f7f\" notitle");
        if (paper)
            fprintf(f, ", '' u 1:22 w lp dt 2 lc rgb \"#0072b2\" pt 6 t \"paper geometry\", '' u 1:23 w lp dt 2 lc "
                       "rgb \"#009e73\" pt 8 t \"paper total\"");
        fprintf(f, "\nunset multiplot\n");
    }
    return ferror(f) ? -1 : 0;
}

/* DIR/NAME-shadows.{dat,gp,png}: Figures 7-9 as curves, the geometry (or,
 * with R->total, total) traffic of recursive over dynamic per cache size
 * with light 0, 1, 2 and all three, the paper's dashed beside ours. */
static int shadows_plot(const rt_report *R, const rt_plot_opts *p, const char *sc, int paper, rt_err *e)
{
    char dat[4096], gpf[4096], png[4200], base[4096];
    rt_plot_path(dat, sizeof dat, p->dir, "", sc, "-shadows.dat");
    rt_plot_path(gpf, sizeof gpf, p->dir, "", sc, "-shadows.gp");
    rt_plot_path(base, sizeof base, p->dir, "", sc, "-shadows");
    snprintf(png, sizeof png, "%s.png", base);
    rt_out *o;
    FILE *f = rt_plot_open(dat, &o, e);
    if (!f) return -1;
    fprintf(f, "# cache_kb, recursive/dynamic with light 0, 1, 2, all (ours), then the paper's\n");
    static const unsigned masks[4] = {1, 2, 4, 7};
    int any = 0;
    for (int k = 0; k < R->nsizes; k++) {
        uint64_t s = R->sizes[k];
        fprintf(f, "%" PRIu64, s / 1024);
        for (int l = 0; l < 4; l++) {
            double g[2], r[2];
            int h0 = rt_report_value(R, sc, "recursive", masks[l], s, &g[0], &r[0], e);
            int h1 = h0 >= 0 ? rt_report_value(R, sc, "dynamic", masks[l], s, &g[1], &r[1], e) : -1;
            if (h0 < 0 || h1 < 0) {
                rt_out_abort(o);
                return -1;
            }
            double b = R->total ? g[0] + r[0] : g[0], d = R->total ? g[1] + r[1] : g[1];
            if (h0 && h1 && b > 0 && d > 0) fprintf(f, " %.6g", b / d), any = 1;
            else fputs(" NaN", f);
        }
        double pg[3], pr[3], ps[4];
        int hp = paper ? rt_report_paper_point(R, sc, s / 1024, pg, pr, ps, e) : 0;
        if (hp < 0) {
            rt_out_abort(o);
            return -1;
        }
        for (int l = 0; l < 4; l++)
            if (hp > 0 && !isnan(ps[l])) fprintf(f, " %.6g", 1.0 + ps[l] / 100.0);
            else fputs(" NaN", f);
        fputc('\n', f);
    }
    if (rt_plot_commit(o, e) < 0) return -1;
    if (!any) { /* no shadow runs: no picture */
        remove(dat);
        return 0;
    }
    if (!(f = rt_plot_open(gpf, &o, e))) return -1;
    fprintf(f, "set terminal pngcairo size 1000,600 font \"sans,11\"\nset output ");
    rt_plot_quote_path(f, png);
    char title[512];
    snprintf(title, sizeof title, "%s: %s traffic, recursive / dynamic, primary + shadow rays, %dx%d%s", sc,
             R->total ? "total" : "geometry", R->W, R->H, paper ? " (dashed: the paper's)" : "");
    fputs("\nset title ", f);
    rt_plot_quote(f, title);
    fprintf(f, " noenhanced\nset logscale xy\nset format y \"%%g\"\nset grid\nset xlabel \"cache size\"\n"
               "set ylabel \"recursive / dynamic (above 1: dynamic moves less)\"\nset key outside right noenhanced\n"
               "set bmargin 6\n");
    size_tics(f, R);
    size_range(f, R);
    static const char *const lc[4] = {"#0072b2", "#e69f00", "#cc79a7", "#009e73"};
    static const char *const ln[4] = {"light 0", "light 1", "light 2", "all 3 lights"};
    fputs("plot ", f);
    rt_plot_quote_path(f, dat);
    for (int l = 0; l < 4; l++)
        fprintf(f, "%s u 1:%d w lp lc rgb \"%s\" pt 7 t \"%s\"", l ? ", ''" : "", 2 + l, lc[l], ln[l]);
    if (paper)
        for (int l = 0; l < 4; l++)
            fprintf(f, ", '' u 1:%d w lp dt 2 lc rgb \"%s\" pt 6 t \"paper %s\"", 6 + l, lc[l], ln[l]);
    fprintf(f, ", 1 w l lc rgb \"#7f7f7f\" notitle\n");
    if (rt_plot_commit(o, e) < 0) return -1;
    const char *outs[] = {png, NULL};
    char what[4300];
    snprintf(what, sizeof what, "%s", png);
    return rt_plot_draw(p, gpf, outs, what, e);
}

int rt_plot_traffic(const rt_report *R, const rt_plot_opts *p, rt_err *e)
{
    if (rt_plot_mkdir(p->dir, e) < 0) return -1;
    const int mb = R->W == 1024 && R->H == 1024;
    for (int i = 0; i < R->nscenes; i++) {
        const char *sc = R->scenes[i];
        char dat[4096], gpf[4096], base[4096], png[4200], svg[4200], what[4300];
        rt_plot_path(dat, sizeof dat, p->dir, "", sc, "-traffic.dat");
        rt_plot_path(gpf, sizeof gpf, p->dir, "", sc, "-traffic.gp");
        rt_plot_path(base, sizeof base, p->dir, "", sc, "-traffic");
        rt_out *o;
        FILE *f = rt_plot_open(dat, &o, e);
        if (!f) return -1;
        fprintf(f, "# cache_kb; geometry, ray, total MB of recursive packet dynamic (primary rays); the paper's "
                   "geometry, ray, total MB; recursive/dynamic geometry and total, ours then the paper's\n");
        int paper = 0;
        for (int k = 0; k < R->nsizes; k++) {
            uint64_t s = R->sizes[k];
            double v[9], pv[9];
            int h[3];
            const rt_tracer *tr[3] = {NULL, NULL, NULL};
            rt_report_fig_tracers(RT_FIG_NAVRATIL, tr, 3);
            for (int t = 0; t < 3; t++) {
                h[t] = tr[t] ? rt_report_value(R, sc, tr[t]->name, 0, s, &v[t], &v[t + 3], e) : 0;
                if (h[t] < 0) {
                    rt_out_abort(o);
                    return -1;
                }
                v[t + 6] = v[t] + v[t + 3];
            }
            h[1] = h[1] && s > (uint64_t)R->packet * R->packet * 32;
            int hp = rt_report_paper_point(R, sc, s / 1024, &pv[0], &pv[3], (double[4]){0}, e);
            if (hp < 0) {
                rt_out_abort(o);
                return -1;
            }
            paper |= hp > 0;
            for (int t = 0; t < 3; t++) pv[t + 6] = pv[t] + pv[t + 3];
            fprintf(f, "%" PRIu64, s / 1024);
            for (int c = 0; c < 9; c++)
                if (h[c % 3] && v[c] > 0) fprintf(f, " %.6g", v[c]);
                else fprintf(f, " NaN");
            for (int c = 0; c < 9; c++)
                if (hp > 0 && pv[c] > 0) fprintf(f, " %.6g", pv[c]);
                else fprintf(f, " NaN");
            const double q[4] = {h[0] && h[2] ? v[0] / v[2] : NAN, h[0] && h[2] ? v[6] / v[8] : NAN,
                                 hp > 0 ? pv[0] / pv[2] : NAN, hp > 0 ? pv[6] / pv[8] : NAN};
            for (int c = 0; c < 4; c++)
                if (q[c] > 0 && isfinite(q[c])) fprintf(f, " %.6g", q[c]);
                else fprintf(f, " NaN");
            fprintf(f, "\n");
        }
        if (rt_plot_commit(o, e) < 0) return -1;
        if (!(f = rt_plot_open(gpf, &o, e))) return -1;
        traffic_script(f, R, sc, dat, base, paper, mb);
        if (rt_plot_commit(o, e) < 0) return -1;
        snprintf(png, sizeof png, "%s.png", base);
        snprintf(svg, sizeof svg, "%s.svg", base);
        snprintf(what, sizeof what, "%s.png and .svg", base);
        const char *outs[] = {png, svg, NULL};
        if (rt_plot_draw(p, gpf, outs, what, e) < 0) return -1;
        if (shadows_plot(R, p, sc, paper, e) < 0) return -1;
    }
    return 0;
}

/* ---- speed against error ----------------------------------------------------------- */

/* Colour-blind-safe and then clearly distinct colours, one per series. */
static const char *const colours[] = {
    "#0072b2", "#e69f00", "#009e73", "#d55e00", "#cc79a7", "#56b4e9", "#000000", "#f0e442",
    "#8c564b", "#7f7f7f", "#17becf", "#bcbd22", "#1f3f8f", "#9467bd", "#2ca02c", "#d62728",
    "#ff9896", "#98df8a", "#c5b0d5", "#aec7e8", "#ffbb78", "#c49c94", "#f7b6d2", "#dbdb8d",
};
static const int points[] = {7, 5, 9, 11, 13, 15};

int rt_plot_speed_error(const rt_plot_opts *p, const char *datpath, const char (*labels)[128], int n, rt_err *e)
{
    char gpath[4096], png[4096];
    snprintf(gpath, sizeof gpath, "%s/speed-error.gp", p->dir);
    snprintf(png, sizeof png, "%s/speed-error.png", p->dir);
    rt_out *o;
    FILE *g = rt_plot_open(gpath, &o, e);
    if (!g) return -1;
    int ncol = (int)(sizeof colours / sizeof colours[0]);
    /* two plots on the top of the page, the key in its own band below the
     * x labels: two entries per row, as many rows as it needs */
    int rows = (n + 1) / 2, H = 560 + 22 * rows;
    double band = (22.0 * rows + 16) / H;
    fprintf(g, "set terminal pngcairo size 1200,%d enhanced\nset output ", H);
    rt_plot_quote_path(g, png);
    fprintf(g, "\nset logscale xy\nset format x \"10^{%%L}\"\nset format y \"10^{%%L}\"\nset xtics 10\nset ytics 10\n"
               "set grid\nset xlabel \"speedup over exact\"\nunset key\n"
               "set multiplot\nset bmargin at screen %.4f\nset tmargin at screen 0.95\n",
            band + 0.09);
    for (int side = 0; side < 2; side++) {
        fprintf(g, "set lmargin at screen %.2f\nset rmargin at screen %.2f\n", side ? 0.57 : 0.08, side ? 0.98 : 0.49);
        fprintf(g, "set ylabel \"%s: mean abs miss-ratio error\"\nplot ", side ? "ray" : "geometry");
        if (!n) fprintf(g, "NaN notitle");
        for (int i = 0; i < n; i++) {
            fprintf(g, "%s", i ? ", \\\n  " : "");
            rt_plot_quote_path(g, datpath);
            fprintf(g, " u ($5==%d?$2:1/0):%d w p pt %d ps 1.1 lc rgb \"%s\" notitle", i, side ? 4 : 3,
                    points[i % 6], colours[i % ncol]);
        }
        fprintf(g, "\n");
    }
    /* the key: an empty plot over the band, one invisible point per series */
    fprintf(g, "unset logscale\nunset border\nunset tics\nunset xlabel\nunset ylabel\nunset grid\n"
               "set lmargin at screen 0.02\nset rmargin at screen 0.98\nset bmargin at screen 0.01\n"
               "set tmargin at screen %.4f\nset xrange [0:1]\nset yrange [0:1]\n"
               "set key inside center center horizontal maxcols 2 width 2 samplen 1 reverse Left noenhanced font \",10\"\nplot ",
            band);
    if (!n) fprintf(g, "NaN notitle");
    for (int i = 0; i < n; i++) {
        fprintf(g, "%sNaN w p pt %d ps 1.1 lc rgb \"%s\" t ", i ? ", \\\n  " : "", points[i % 6], colours[i % ncol]);
        rt_plot_quote(g, labels[i]);
    }
    fprintf(g, "\nunset multiplot\n");
    if (rt_plot_commit(o, e) < 0) return -1;
    const char *outs[] = {png, NULL};
    return rt_plot_draw(p, gpath, outs, png, e);
}

/* ---- scene thumbnails --------------------------------------------------------------- */

int rt_plot_scenes(const rt_report *R, const rt_plot_opts *p, rt_err *e)
{
    const int tile = 256, n = R->nscenes;
    if (n <= 0) return 0;
    if (rt_plot_mkdir(p->dir, e) < 0) return -1;
    unsigned char *all = rt_calloc((size_t)tile * n * tile * 3, 1, e);
    unsigned char *px = rt_calloc((size_t)tile * tile * 3, 1, e);
    int rc = all && px ? 0 : -1;
    for (int i = 0; i < n && rc == 0; i++) {
        rt_render_opts o;
        rt_render_default_opts(&o);
        o.W = o.H = tile;
        o.lights = 7;
        rt_job j;
        rt_run_stats st;
        /* a mesh from where the database last saw it (works from any
         * folder); a built-in by its name */
        char spec[4400];
        if (R->scene_abspath[i][0]) snprintf(spec, sizeof spec, "%s", R->scene_abspath[i]);
        else {
            /* a built-in at its stored parameters (sphereflake:level=2 is
             * not the default sphereflake) */
            char prm[256] = "";
            sqlite3_stmt *q = rt_report_stmt(R->h, "SELECT params FROM scenes WHERE name = ?1 AND hash = ?2 LIMIT 1",
                                              R->dbpath, e, "ss", R->scene_name[i], R->scene_hash[i]);
            if (!q) {
                rc = -1;
                break;
            }
            int src = sqlite3_step(q);
            if (src == SQLITE_ROW && sqlite3_column_text(q, 0))
                snprintf(prm, sizeof prm, "%s", (const char *)sqlite3_column_text(q, 0));
            if (rt_report_done(q, src, R->dbpath, e) < 0) {
                rc = -1;
                break;
            }
            snprintf(spec, sizeof spec, "%s%s%s", R->scene_name[i], prm[0] ? ":" : "", prm);
        }
        if (rt_job_setup(&j, spec, rt_tracer_reference()->name, &o, e) < 0) {
            /* e names the scene file that could not be loaded */
            if (e) {
                char m[RT_ERR_LEN];
                snprintf(m, sizeof m, "%s", e->msg);
                rt_errf(e, "scene thumbnails: %s", m);
            }
            rc = -1;
            break;
        }
        rt_image *im = rt_image_new(tile, tile, e);
        rc = im ? rt_job_run(&j, NULL, im, &st, e) : -1;
        rt_job_free(&j);
        if (rc == 0) rt_image_to_rgb8(im, px);
        rt_image_free(im);
        if (rc < 0) break;
        for (int y = 0; y < tile; y++)
            memcpy(all + ((size_t)y * tile * n + (size_t)i * tile) * 3, px + (size_t)y * tile * 3, (size_t)tile * 3);
    }
    char path[4096], strip[4096], gpf[4096];
    snprintf(path, sizeof path, "%s/scenes.png", p->dir);
    snprintf(strip, sizeof strip, "%s/scenes-tiles.png", p->dir);
    snprintf(gpf, sizeof gpf, "%s/scenes.gp", p->dir);
    /* the tiles side by side; with gnuplot, scenes.png is that strip with
     * each scene's name above its tile, else the strip itself */
    if (rc == 0) rc = rt_png_write_rgb8(p->gnuplot ? strip : path, tile * n, tile, all, e);
    free(px);
    free(all);
    if (rc == 0 && p->gnuplot) {
        rt_out *o;
        FILE *f = rt_plot_open(gpf, &o, e);
        if (!f) return -1;
        fprintf(f, "set terminal pngcairo size %d,%d font \"sans,10\"\nset output ", tile * n + 8 * n, tile + 44);
        rt_plot_quote_path(f, path);
        fprintf(f, "\nunset border\nunset tics\nunset key\nset size ratio -1\n"
                   "set multiplot layout 1,%d margins 0.002,0.998,0.01,0.88 spacing 0.004,0\n", n);
        for (int i = 0; i < n; i++) {
            fprintf(f, "set title ");
            rt_plot_quote(f, R->scenes[i]);
            fprintf(f, " noenhanced\nset xrange [%d:%d]\nset yrange [0:%d]\nplot ", i * tile, (i + 1) * tile, tile);
            rt_plot_quote_path(f, strip);
            fprintf(f, " binary filetype=png with rgbimage\n");
        }
        fprintf(f, "unset multiplot\n");
        if (rt_plot_commit(o, e) < 0) return -1;
        const char *outs[] = {path, NULL};
        return rt_plot_draw(p, gpf, outs, path, e);
    }
    if (rc == 0 && p->log) fprintf(p->log, "wrote %s\n", path);
    return rc;
}
