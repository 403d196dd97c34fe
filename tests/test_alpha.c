/*
 * test_alpha.c -- alpha cutouts (src/alpha.h): the filter on a hand-made
 * texture, every structure's walk against brute force, the brute force
 * against a reference written here from the definitions, the memory
 * model's reads, the checker, and the image decoders on files written
 * here.
 *
 *   test_alpha                     the tests
 *   test_alpha --png PATH W H V..  writes a W x H 8-bit PNG whose R channel
 *                                  holds the values V (0..255, row 0 on top)
 *   test_alpha --exr PATH W H V..  writes a float EXR whose R channel holds V
 *   (alpha_cli.sh makes its images with these)
 */
#include "accel.h"
#include "alpha.h"
#include "check.h"
#include "image.h"
#include "scene.h"
#include "scene_load.h"

/* A quad [x0,x1] x [y0,y1] at height z facing +z, two triangles (a b c),
 * (a c d) with uv = ((x - x0) / (x1 - x0), (y - y0) / (y1 - y0)). */
static void add_quad(rt_scene *s, float x0, float y0, float x1, float y1, float z, float *uv)
{
    static const float rgb[3] = {0.5f, 0.5f, 0.5f};
    rt_vec3 a = rt_v3(x0, y0, z), b = rt_v3(x1, y0, z), c = rt_v3(x1, y1, z), d = rt_v3(x0, y1, z);
    rt_scene_add_tri(s, a, b, c, rgb, NULL);
    rt_scene_add_tri(s, a, c, d, rgb, NULL);
    if (uv) {
        const float t0[6] = {0, 0, 1, 0, 1, 1}, t1[6] = {0, 0, 1, 1, 0, 1};
        memcpy(uv, t0, sizeof t0);
        memcpy(uv + 6, t1, sizeof t1);
    }
}

/* The reference: texel of (s, t) by the definition (nearest, t flipped,
 * repeat), written out apart from alpha.c. */
static float ref_texel(const rt_scene_alpha *A, uint32_t map, double s, double t)
{
    const rt_alpha_map *m = &A->map[map];
    long x = (long)floor(s * m->w), y = (long)floor((1.0 - t) * m->h);
    x %= (long)m->w;
    y %= (long)m->h;
    if (x < 0) x += m->w;
    if (y < 0) y += m->h;
    return A->texel[m->off + (uint64_t)y * m->w + (uint64_t)x];
}

/* The reference closest hit: every triangle, its alpha by the definition
 * (pbrt's rule with the hash the library computes: the hash itself is
 * checked apart, below). */
static int ref_closest(const rt_scene *sc, const rt_ray *r, rt_hit *h)
{
    const rt_scene_alpha *A = sc->alpha;
    rt_hit_none(h);
    float best = r->tmax;
    for (uint32_t i = 0; i < sc->ntri; i++) {
        float t, u, v;
        if (!rt_isect_core(r, &sc->tri[i], &t, &u, &v) || !(t > r->tmin && t < best)) continue;
        if (A && i < A->nrec && A->tmap[i]) {
            const float *q = A->uv + 6 * (size_t)i;
            const float w0 = 1.0f - u - v;
            float a = ref_texel(A, A->tmap[i] - 1, w0 * q[0] + u * q[2] + v * q[4], w0 * q[1] + u * q[3] + v * q[5]);
            if (a <= 0 || (a < 1 && rt_alpha_hash(r) > a)) continue;
        }
        best = t;
        h->t = t, h->tri = i, h->u = u, h->v = v;
    }
    return h->tri != RT_NO_HIT;
}

static rt_scene_alpha *new_alpha(uint32_t ntri, uint32_t nmap, const uint32_t *w, const uint32_t *hh)
{
    rt_scene_alpha *A = calloc(1, sizeof *A);
    A->ntri = A->nrec = ntri;
    A->nmap = nmap;
    A->map = calloc(nmap, sizeof *A->map);
    uint64_t off = 0;
    for (uint32_t k = 0; k < nmap; k++) {
        A->map[k].w = w[k], A->map[k].h = hh[k], A->map[k].off = off;
        off += (uint64_t)w[k] * hh[k];
    }
    A->ntexel = off;
    A->texel = calloc(off, sizeof *A->texel);
    A->tmap = calloc(ntri, sizeof *A->tmap);
    A->uv = calloc((size_t)ntri * 6, sizeof *A->uv);
    return A;
}

static rt_layout empty; /* the walks look their regions up in a layout, none here */

static int drop_put(rt_sink *sn, const rt_access *a, size_t k)
{
    (void)sn, (void)a, (void)k;
    return 0;
}

/* A 4x4 mask with zeros where the pattern says, on a unit quad over an
 * opaque floor: rays straight down at every texel centre hit the quad
 * exactly where the mask is 1, the floor where it is 0. */
static void test_hand(void)
{
    static const char pat[4][5] = {"1101", "0110", "1000", "1111"}; /* row 0 = top of the image (v = 1) */
    rt_scene *s = rt_scene_new(4, NULL);
    float uv[12];
    add_quad(s, 0, 0, 1, 1, 0, uv);         /* triangles 0, 1: the card */
    add_quad(s, -1, -1, 2, 2, -1, NULL);    /* 2, 3: the floor */
    const uint32_t w = 4, h = 4;
    s->alpha = new_alpha(4, 1, &w, &h);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++) s->alpha->texel[y * 4 + x] = pat[y][x] == '1' ? 1.0f : 0.0f;
    s->alpha->tmap[0] = s->alpha->tmap[1] = 1;
    memcpy(s->alpha->uv, uv, sizeof uv);
    rt_err e = {0};
    CHECK(rt_scene_finish(s, &e) == 0 && rt_alpha_check(s->alpha, &e) == 0, "hand scene: %s", e.msg);
    rt_accel acc[RT_ACCEL_NKINDS];
    int have[RT_ACCEL_NKINDS] = {0};
    for (int k = RT_ACCEL_KD; k < RT_ACCEL_NKINDS; k++) have[k] = rt_accel_build(&acc[k], k, s, NULL, &e) == 0;
    CHECK(have[RT_ACCEL_KD] && have[RT_ACCEL_BVH2] && have[RT_ACCEL_BVH4] && have[RT_ACCEL_BVH8] && have[RT_ACCEL_GRID] &&
              have[RT_ACCEL_NAIVE] && have[RT_ACCEL_INST],
          "builds: %s", e.msg);
    int bad = 0, n = 0;
    for (int sy = 0; sy < 16; sy++)
        for (int sx = 0; sx < 16; sx++) { /* 4 x 4 rays per texel, inside it */
            float px = (sx + 0.5f) / 16, py = (sy + 0.5f) / 16;
            int tx = sx / 4, ty = 3 - sy / 4; /* v = py: row 0 is the top (v near 1) */
            int open = pat[ty][tx] == '0';
            rt_ray r;
            rt_ray_init(&r, rt_v3(px, py, 1), rt_v3(0.01f * (sx - 8) / 8, 0.013f * (sy - 8) / 8, -1));
            r.tmin = 0;
            rt_hit hb;
            rt_brute_closest(s, &r, &hb);
            int want_floor = open;
            int got_floor = hb.tri == 2 || hb.tri == 3;
            bad += got_floor != want_floor;
            /* a shadow ray from under the card up to the sky: blocked where the mask is 1 */
            rt_ray up;
            rt_ray_init(&up, rt_v3(px, py, -0.5f), rt_v3(0, 0, 1));
            up.tmin = 0, up.tmax = 10;
            bad += rt_brute_occluded(s, &up) != !open;
            for (int k = RT_ACCEL_KD; k < RT_ACCEL_NKINDS; k++) {
                if (!have[k]) continue;
                rt_trav tv;
                rt_accel_trav(&acc[k], &tv, s, NULL, &empty);
                rt_hit hk;
                acc[k].ops->closest(&tv, &r, &hk);
                bad += hk.tri != hb.tri || hk.t != hb.t;
                bad += acc[k].ops->occluded(&tv, &up) != !open;
                n++;
            }
        }
    CHECK(bad == 0 && n > 0, "hand mask: %d of the hits or shadow rays wrong", bad);
    /* without the mask every ray hits the card */
    rt_scene_alpha *A = s->alpha;
    s->alpha = NULL;
    rt_ray r;
    rt_ray_init(&r, rt_v3(0.1f, 0.55f, 1), rt_v3(0, 0, -1)); /* texel (0, 1): open */
    rt_hit hh;
    CHECK(rt_brute_closest(s, &r, &hh) && hh.tri <= 1, "opaque: tri %u", hh.tri);
    s->alpha = A;
    CHECK(rt_brute_closest(s, &r, &hh) && hh.tri >= 2, "cut: tri %u", hh.tri);
    /* the reads of one test: the 28-byte record and one texel */
    rt_layout L;
    rt_mm_init(&L);
    CHECK(rt_alpha_regions(&L, s->alpha, &e) == 0 && L.n == 2 && L.r[0].cls == RT_CLS_ALPHA &&
              L.r[1].cls == RT_CLS_ALPHA && L.r[0].count == 4 && L.r[1].count == 16,
          "regions: %s", e.msg);
    rt_sink sk = {drop_put, NULL};
    rt_rec *rec = rt_rec_new(&sk, &e); /* the test reads rec->buf before any flush */
    rt_alpha_at at;
    rt_alpha_at_init(&at, &L);
    /* triangle 1 (a c d), uv (0,0) (1,1) (0,1): at barycentrics (0.2, 0.4)
     * uv = 0.2 (1,1) + 0.4 (0,1) = (0.2, 0.6): x = floor(0.8) = 0, row
     * floor((1 - 0.6) 4) = 1, texel 4, pattern row 1 "0110": 0 */
    float a = rt_alpha_value(s->alpha, &at, rec, 1, 0.2f, 0.4f);
    CHECK(a == 0.0f && rec->n == 2, "value %g, %zu reads", (double)a, rec->n);
    if (rec->n == 2) {
        CHECK(rec->buf[0].addr == L.r[0].base + 28 && rec->buf[0].size == 28 && rec->buf[0].cls == RT_CLS_ALPHA,
              "record read %#llx %u", (unsigned long long)rec->buf[0].addr, rec->buf[0].size);
        CHECK(rec->buf[1].addr == L.r[1].base + 4 * (1 * 4 + 0) && rec->buf[1].size == 4, "texel read %#llx",
              (unsigned long long)rec->buf[1].addr);
    }
    rec->n = 0;
    CHECK(rt_alpha_value(s->alpha, &at, rec, 2, 0.2f, 0.4f) == 1.0f && rec->n == 1 && rec->buf[0].size == 4 &&
              rec->buf[0].addr == L.r[0].base + 56,
          "an opaque triangle reads 4 bytes of its record");
    rec->n = 0;
    rt_rec_free(rec);
    for (int k = RT_ACCEL_KD; k < RT_ACCEL_NKINDS; k++)
        if (have[k]) rt_accel_free(&acc[k]);
    rt_scene_free(s);
}

/* pbrt's HashFloat(o, d): MurmurHash64A of the 24 bytes, written out here
 * from its definition (util/hash.h), on one known ray. */
static void test_hash(void)
{
    rt_ray r;
    rt_ray_init(&r, rt_v3(1, 2, 3), rt_v3(-0.5f, 0.25f, 1));
    const float f[6] = {1, 2, 3, -0.5f, 0.25f, 1};
    unsigned char b[24];
    memcpy(b, f, 24); /* the machines the project runs on are little-endian */
    const uint64_t m = 0xc6a4a7935bd1e995ull;
    uint64_t h = 0 ^ (24 * m);
    for (int i = 0; i < 3; i++) {
        uint64_t k;
        memcpy(&k, b + 8 * i, 8);
        k *= m, k ^= k >> 47, k *= m;
        h ^= k, h *= m;
    }
    h ^= h >> 47, h *= m, h ^= h >> 47;
    float want = (float)(uint32_t)h * 0x1p-32f;
    CHECK(rt_alpha_hash(&r) == want && want >= 0 && want <= 1, "hash %a, expected %a", (double)rt_alpha_hash(&r),
          (double)want);
}

/* Random cards with random masks (zeros, ones and partial values) over a
 * floor: every structure's closest and any-hit walks equal brute force,
 * and brute force equals the reference above. */
static void test_random(void)
{
    rnd_seed(37);
    const int ncard = check_long() ? 400 : 60, nray = check_long() ? 20000 : 3000;
    rt_scene *s = rt_scene_new(0, NULL);
    const uint32_t w[3] = {5, 8, 1}, hh[3] = {3, 8, 1};
    uint32_t ntri = 2 * (uint32_t)ncard + 2;
    float *uv = calloc((size_t)ntri * 6, sizeof *uv);
    uint32_t *tm = calloc(ntri, sizeof *tm);
    for (int c = 0; c < ncard; c++) {
        float x = uf(-1, 1), y = uf(-1, 1), z = uf(-1, 1), sz = uf(0.05f, 0.4f);
        add_quad(s, x, y, x + sz, y + sz * uf(0.5f, 2), z, uv + 12 * (size_t)c);
        for (int j = 0; j < 12; j++) uv[12 * (size_t)c + j] = uv[12 * (size_t)c + j] * 2 - 0.5f; /* repeat wraps */
        tm[2 * c] = tm[2 * c + 1] = (uint32_t)(rnd64() % 4); /* 0: opaque */
    }
    add_quad(s, -2, -2, 2, 2, -1.5f, NULL);
    s->alpha = new_alpha(ntri, 3, w, hh);
    memcpy(s->alpha->uv, uv, (size_t)ntri * 6 * sizeof *uv);
    memcpy(s->alpha->tmap, tm, ntri * sizeof *tm);
    for (uint64_t i = 0; i < s->alpha->ntexel; i++) {
        uint64_t q = rnd64() % 4;
        s->alpha->texel[i] = q == 0 ? 0.0f : q == 1 ? 1.0f : q == 2 ? 0.5f : 0.0f;
    }
    s->alpha->texel[s->alpha->ntexel - 1] = 0.25f; /* the 1 x 1 map: a constant partial alpha */
    free(uv);
    free(tm);
    rt_err e = {0};
    CHECK(rt_scene_finish(s, &e) == 0 && rt_alpha_check(s->alpha, &e) == 0, "random scene: %s", e.msg);
    rt_accel acc[RT_ACCEL_NKINDS];
    int have[RT_ACCEL_NKINDS] = {0};
    for (int k = RT_ACCEL_KD; k < RT_ACCEL_NKINDS; k++) have[k] = rt_accel_build(&acc[k], k, s, NULL, &e) == 0;
    int bad_ref = 0, bad[RT_ACCEL_NKINDS] = {0}, cuts = 0;
    for (int i = 0; i < nray; i++) {
        rt_ray r;
        rt_vec3 o = rt_v3(uf(-1.5f, 1.5f), uf(-1.5f, 1.5f), 2), tg = rt_v3(uf(-1, 1), uf(-1, 1), -1.5f);
        rt_ray_init(&r, o, rt_v3(tg.x - o.x, tg.y - o.y, tg.z - o.z));
        r.tmin = 0;
        if (i % 3 == 0) r.tmax = uf(0.2f, 1.0f);
        rt_hit hb, hr;
        rt_brute_closest(s, &r, &hb);
        ref_closest(s, &r, &hr);
        bad_ref += hb.tri != hr.tri || hb.t != hr.t;
        rt_scene_alpha *A = s->alpha;
        s->alpha = NULL;
        rt_hit ho;
        rt_brute_closest(s, &r, &ho);
        s->alpha = A;
        cuts += ho.tri != hb.tri;
        int occ = rt_brute_occluded(s, &r);
        for (int k = RT_ACCEL_KD; k < RT_ACCEL_NKINDS; k++) {
            if (!have[k]) continue;
            rt_trav tv;
            rt_accel_trav(&acc[k], &tv, s, NULL, &empty);
            rt_hit hk;
            acc[k].ops->closest(&tv, &r, &hk);
            bad[k] += hk.tri != hb.tri || (hb.tri != RT_NO_HIT && hk.t != hb.t);
            bad[k] += acc[k].ops->occluded(&tv, &r) != occ;
        }
    }
    CHECK(bad_ref == 0, "brute force differs from the reference on %d rays", bad_ref);
    CHECK(cuts > nray / 20, "only %d of %d rays see a cutout: the test does not test much", cuts, nray);
    for (int k = RT_ACCEL_KD; k < RT_ACCEL_NKINDS; k++) {
        CHECK(bad[k] == 0, "%s: %d rays differ from brute force", rt_accel_name(k), bad[k]);
        if (have[k]) rt_accel_free(&acc[k]);
    }
    rt_scene_free(s);
}

static void test_check(void)
{
    const uint32_t w = 2, h = 2;
    rt_scene_alpha *A = new_alpha(3, 1, &w, &h);
    rt_err e = {0};
    CHECK(rt_alpha_check(A, &e) < 0 && strstr(e.msg, "no triangle"), "no textured triangle: %s", e.msg);
    A->tmap[1] = 1;
    CHECK(rt_alpha_check(A, &e) == 0, "valid: %s", e.msg);
    A->tmap[2] = 2;
    CHECK(rt_alpha_check(A, &e) < 0 && strstr(e.msg, "names texture 2"), "bad map: %s", e.msg);
    A->tmap[2] = 0;
    A->texel[3] = -1;
    CHECK(rt_alpha_check(A, &e) < 0 && strstr(e.msg, "texel 3"), "negative texel: %s", e.msg);
    A->texel[3] = 0;
    A->uv[7] = NAN;
    CHECK(rt_alpha_check(A, &e) < 0 && strstr(e.msg, "triangle 1"), "NaN uv: %s", e.msg);
    A->uv[7] = 0;
    A->map[0].w = 3;
    CHECK(rt_alpha_check(A, &e) < 0 && strstr(e.msg, "texture 0"), "map past the texels: %s", e.msg);
    rt_alpha_free(A);
}

/* The decoders on images written by the project's own writers. */
static void test_decode(void)
{
    const int W = 5, H = 3;
    unsigned char rgb[5 * 3 * 3];
    for (int i = 0; i < W * H; i++) rgb[3 * i] = (unsigned char)(i * 17), rgb[3 * i + 1] = 200, rgb[3 * i + 2] = 9;
    const char *pp = check_path("m.png"), *pe = check_path("m.exr");
    rt_err e = {0};
    CHECK(rt_png_write_rgb8(pp, W, H, rgb, &e) == 0, "png write: %s", e.msg);
    rt_image *im = rt_image_new(W, H, &e);
    for (int i = 0; i < W * H; i++) im->rgb[3 * i] = (float)i / 8, im->rgb[3 * i + 1] = 7;
    CHECK(rt_exr_write(pe, im, NULL, 0, &e) == 0, "exr write: %s", e.msg);
    rt_image_free(im);
    FILE *f = fopen(pp, "rb");
    unsigned char buf[65536];
    size_t n = f ? fread(buf, 1, sizeof buf, f) : 0;
    if (f) fclose(f);
    float *px = NULL;
    uint32_t w = 0, h = 0;
    CHECK(rt_alpha_decode_png(buf, n, pp, 0, &px, &w, &h, &e) == 0 && w == 5 && h == 3, "png: %s", e.msg);
    int bad = 0;
    for (int i = 0; px && i < W * H; i++) bad += px[i] != (float)((i * 17) / 255.0);
    CHECK(bad == 0, "png: %d texels differ", bad);
    free(px);
    CHECK(rt_alpha_decode_png(buf, n, pp, 1, &px, &w, &h, &e) == 0 && px && px[0] == 0 && px[15 - 1] < 1 &&
              fabs(px[1] - pow((17 / 255.0 + 0.055) / 1.055, 2.4)) < 1e-6,
          "png sRGB: %s", e.msg);
    free(px);
    /* truncated and corrupted: one-line errors with the name */
    CHECK(rt_alpha_decode_png(buf, n / 2, "cut.png", 0, &px, &w, &h, &e) < 0 && strstr(e.msg, "cut.png: PNG") &&
              !strchr(e.msg, '\n'),
          "truncated png: %s", e.msg);
    CHECK(rt_alpha_decode_png(buf + 1, n - 1, "junk.png", 0, &px, &w, &h, &e) < 0 && strstr(e.msg, "junk.png: not a PNG"),
          "junk png: %s", e.msg);
    f = fopen(pe, "rb");
    n = f ? fread(buf, 1, sizeof buf, f) : 0;
    if (f) fclose(f);
    CHECK(rt_alpha_decode_exr(buf, n, pe, &px, &w, &h, &e) == 0 && w == 5 && h == 3, "exr: %s", e.msg);
    bad = 0;
    for (int i = 0; px && i < W * H; i++) bad += px[i] != (float)i / 8;
    CHECK(bad == 0, "exr: %d texels differ", bad);
    free(px);
    CHECK(rt_alpha_decode_exr(buf, n - 20, "cut.exr", &px, &w, &h, &e) < 0 && strstr(e.msg, "cut.exr: OpenEXR") &&
              !strchr(e.msg, '\n'),
          "truncated exr: %s", e.msg);
    CHECK(rt_alpha_decode_exr(buf + 4, n - 4, "junk.exr", &px, &w, &h, &e) < 0 && strstr(e.msg, "junk.exr: not an OpenEXR"),
          "junk exr: %s", e.msg);
}

/* The loader: a Texture on a PNG, a trianglemesh with uv and one with
 * pbrt's default uv, a bilinearmesh; scale and invert; the scene's
 * structure passes its checker and its hash changes with the mask. */
static void test_load(void)
{
    const char *pp = check_path("leaf.png"), *ps = check_path("a.pbrt");
    unsigned char rgb[2 * 2 * 3] = {255, 0, 0, 0, 0, 0, 0, 0, 0, 255, 0, 0}; /* R: 1 0 / 0 1 */
    rt_err e = {0};
    CHECK(rt_png_write_rgb8(pp, 2, 2, rgb, &e) == 0, "png: %s", e.msg);
    FILE *f = fopen(ps, "w");
    fprintf(f, "WorldBegin\n"
               "Texture \"m\" \"float\" \"imagemap\" \"string filename\" \"leaf.png\" \"string filter\" \"point\"\n"
               "Texture \"inv\" \"float\" \"imagemap\" \"string filename\" \"leaf.png\" \"bool invert\" true "
               "\"float scale\" 0.5 \"string filter\" \"point\"\n"
               "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 1 1 0 0 1 0] \"integer indices\" [0 1 2 0 2 3] "
               "\"point2 uv\" [0 0 1 0 1 1 0 1] \"texture alpha\" \"m\"\n"
               "Shape \"trianglemesh\" \"point3 P\" [0 0 -1 1 0 -1 1 1 -1] \"texture alpha\" \"inv\"\n"
               "Shape \"bilinearmesh\" \"point3 P\" [0 0 -2 1 0 -2 0 1 -2 1 1 -2] \"texture alpha\" \"m\"\n"
               "Shape \"trianglemesh\" \"point3 P\" [0 0 -3 1 0 -3 1 1 -3]\n");
    fclose(f);
    rt_scene *s = rt_scene_load(ps, &e);
    CHECK(s && s->alpha, "load: %s", e.msg);
    if (s && s->alpha) {
        const rt_scene_alpha *A = s->alpha;
        CHECK(rt_alpha_check(A, &e) == 0 && A->nmap == 2 && A->ntexel == 8 && s->ntri == 6 && A->ntri == 6 &&
                  A->nrec == 5,
              "structure (%u of %u triangle records): %s", A->nrec, A->ntri, e.msg);
        static const uint32_t tm[5] = {1, 1, 2, 1, 1}; /* the last, opaque triangle has no record */
        int bad = 0;
        for (int t = 0; t < 5 && A->nrec == 5; t++) bad += A->tmap[t] != tm[t];
        CHECK(bad == 0, "triangle maps");
        static const float inv[4] = {0.5f, 1, 1, 0.5f}; /* max(0, 1 - 0.5 v) */
        bad = 0;
        for (int i = 0; i < 4; i++) bad += A->texel[i] != (i == 0 || i == 3 ? 1.0f : 0.0f) || A->texel[4 + i] != inv[i];
        CHECK(bad == 0, "texels: %g %g %g %g / %g %g %g %g", A->texel[0], A->texel[1], A->texel[2], A->texel[3],
              A->texel[4], A->texel[5], A->texel[6], A->texel[7]);
        /* the default uv of a triangle (0,0) (1,0) (1,1); the patch's second triangle (p00 p11 p01) */
        const float *u2 = A->uv + 12, *u4 = A->uv + 24;
        CHECK(u2[0] == 0 && u2[2] == 1 && u2[3] == 0 && u2[4] == 1 && u2[5] == 1, "default uv");
        CHECK(u4[0] == 0 && u4[1] == 0 && u4[2] == 1 && u4[3] == 1 && u4[4] == 0 && u4[5] == 1, "patch uv");
        uint64_t h1 = rt_scene_hash(s);
        s->alpha->texel[1] = 1;
        CHECK(rt_scene_hash(s) != h1, "the hash ignores the mask");
    }
    rt_scene_free(s);
}

static int write_image(int argc, char **argv)
{
    if (argc < 5) return 2;
    int W = atoi(argv[3]), H = atoi(argv[4]);
    if (W < 1 || H < 1 || argc != 5 + W * H) return fprintf(stderr, "test_alpha: need W x H values\n"), 2;
    rt_err e = {0};
    int rc;
    if (!strcmp(argv[1], "--png")) {
        unsigned char *rgb = calloc((size_t)W * H * 3, 1);
        for (int i = 0; i < W * H; i++) rgb[3 * i] = (unsigned char)atoi(argv[5 + i]);
        rc = rt_png_write_rgb8(argv[2], W, H, rgb, &e);
        free(rgb);
    } else {
        rt_image *im = rt_image_new(W, H, &e);
        for (int i = 0; im && i < W * H; i++) im->rgb[3 * i] = (float)atof(argv[5 + i]);
        rc = im ? rt_exr_write(argv[2], im, NULL, 0, &e) : -1;
        rt_image_free(im);
    }
    if (rc < 0) fprintf(stderr, "test_alpha: %s\n", e.msg);
    return rc < 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--png") || !strcmp(argv[1], "--exr"))) return write_image(argc, argv);
    if (!check_tmpdir("test_alpha")) return perror("mkdtemp"), 1;
    rt_mm_init(&empty);
    test_hash();
    test_hand();
    test_random();
    test_check();
    test_decode();
    test_load();
    check_rmdir();
    if (failures) fprintf(stderr, "test_alpha: %d failure(s)\n", failures);
    return failures ? 1 : 0;
}
