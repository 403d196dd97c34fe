/*
 * exr.c -- OpenEXR output and input through the C API (OpenEXRCore).
 *
 * Images are written as one scanline part with 32-bit float channels
 * B, G, R, Z, nodes, tests (OpenEXR keeps channels sorted by name) and ZIP
 * compression; provenance goes into string attributes. OpenEXRCore's
 * default error handler prints to stderr, which a library must not do, so
 * a silent handler keeps the last message for our one-line error instead.
 *
 * OpenEXRCore seeks back to fill in the chunk offset table, and its own
 * temporary-file mode leaves "tmp.PID..." files behind on failure and
 * replaces devices. So the file is encoded into memory through a custom
 * write stream and then written in one piece through outfile.c, which
 * gives every output the same rules (complete or absent, devices and
 * FIFOs written in place, symlinks followed).
 */
#include "image.h"
#include "outfile.h"

#include <openexr.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static _Thread_local char exr_last_msg[256];

static void quiet_handler(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(exr_last_msg, sizeof exr_last_msg, "%s", msg ? msg : exr_get_error_code_as_string(code));
}

static int exr_fail(rt_err *e, const char *path, const char *what, exr_result_t rv)
{
    return rt_errf(e, "%s: %s: %s", path, what, exr_last_msg[0] ? exr_last_msg : exr_get_error_code_as_string(rv));
}

/* The whole file in memory; OpenEXRCore writes at arbitrary offsets. */
typedef struct membuf {
    unsigned char *p; /* bytes written so far */
    size_t n;         /* file length: highest offset written */
    size_t cap;       /* allocated */
} membuf;

static int64_t mem_write(exr_const_context_t ctxt, void *ud, const void *buf, uint64_t sz, uint64_t off,
                         exr_stream_error_func_ptr_t error_cb)
{
    membuf *m = ud;
    if (off > SIZE_MAX / 2 || sz > SIZE_MAX / 2 - off) {
        error_cb(ctxt, EXR_ERR_OUT_OF_MEMORY, "image too large to encode in memory");
        return -1;
    }
    size_t end = (size_t)(off + sz);
    if (end > m->cap) {
        size_t cap = m->cap ? m->cap : 1 << 16;
        while (cap < end) cap *= 2;
        unsigned char *q = realloc(m->p, cap);
        if (!q) {
            error_cb(ctxt, EXR_ERR_OUT_OF_MEMORY, "out of memory encoding the image");
            return -1;
        }
        m->p = q;
        m->cap = cap;
    }
    if (off > m->n) memset(m->p + m->n, 0, (size_t)off - m->n);
    memcpy(m->p + off, buf, (size_t)sz);
    if (end > m->n) m->n = end;
    return (int64_t)sz;
}

/* Plane of im for a channel name, or NULL. */
static float *plane(const rt_image *im, const char *name, int *stride, int *offset)
{
    *stride = 1;
    *offset = 0;
    if (!strcmp(name, "R") || !strcmp(name, "G") || !strcmp(name, "B")) {
        *stride = 3;
        *offset = name[0] == 'R' ? 0 : (name[0] == 'G' ? 1 : 2);
        return im->rgb;
    }
    if (!strcmp(name, "Z")) return im->depth;
    if (!strcmp(name, "nodes")) return im->nodes;
    if (!strcmp(name, "tests")) return im->tests;
    return NULL;
}

int rt_exr_write(const char *path, const rt_image *im, const rt_exr_attr *attrs, int nattrs, rt_err *e)
{
    static const char *const names[] = {"R", "G", "B", "Z", "nodes", "tests"};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    membuf mem = {NULL, 0, 0};
    init.error_handler_fn = quiet_handler;
    init.user_data = &mem;
    init.write_fn = mem_write;
    exr_context_t f = NULL;
    exr_encode_pipeline_t enc;
    int have_enc = 0, part = 0, rc = -1;
    exr_result_t rv;
    exr_last_msg[0] = 0;

    if (!path[0]) return rt_errf(e, "empty output file name");
    rv = exr_start_write(&f, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS) {
        free(mem.p);
        return exr_fail(e, path, "cannot create", rv);
    }
    if ((rv = exr_add_part(f, "render", EXR_STORAGE_SCANLINE, &part)) ||
        (rv = exr_initialize_required_attr_simple(f, part, im->W, im->H, EXR_COMPRESSION_ZIP))) {
        exr_fail(e, path, "header", rv);
        goto done;
    }
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        if ((rv = exr_add_channel(f, part, names[i], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1))) {
            exr_fail(e, path, "channel", rv);
            goto done;
        }
    }
    for (int i = 0; i < nattrs; i++) {
        if ((rv = exr_attr_set_string(f, part, attrs[i].name, attrs[i].value))) {
            exr_fail(e, path, "attribute", rv);
            goto done;
        }
    }
    if ((rv = exr_write_header(f))) {
        exr_fail(e, path, "write header", rv);
        goto done;
    }
    int32_t spc = 1;
    if ((rv = exr_get_scanlines_per_chunk(f, part, &spc))) {
        exr_fail(e, path, "chunking", rv);
        goto done;
    }
    for (int y = 0; y < im->H; y += spc) {
        exr_chunk_info_t ci;
        if ((rv = exr_write_scanline_chunk_info(f, part, y, &ci))) {
            exr_fail(e, path, "chunk", rv);
            goto done;
        }
        rv = have_enc ? exr_encoding_update(f, part, &ci, &enc) : exr_encoding_initialize(f, part, &ci, &enc);
        if (rv) {
            exr_fail(e, path, "encoder", rv);
            goto done;
        }
        for (int c = 0; c < enc.channel_count; c++) {
            int stride, off;
            float *p = plane(im, enc.channels[c].channel_name, &stride, &off);
            enc.channels[c].user_pixel_stride = (int32_t)(stride * sizeof(float));
            enc.channels[c].user_line_stride = (int32_t)(stride * sizeof(float) * (size_t)im->W);
            enc.channels[c].user_bytes_per_element = sizeof(float);
            enc.channels[c].user_data_type = EXR_PIXEL_FLOAT;
            enc.channels[c].encode_from_ptr = (const uint8_t *)(p + ((size_t)y * im->W) * stride + off);
        }
        if (!have_enc) {
            have_enc = 1;
            if ((rv = exr_encoding_choose_default_routines(f, part, &enc))) {
                exr_fail(e, path, "encoder", rv);
                goto done;
            }
        }
        if ((rv = exr_encoding_run(f, part, &enc))) {
            exr_fail(e, path, "encode", rv);
            goto done;
        }
    }
    rc = 0;
done:
    if (have_enc) exr_encoding_destroy(f, &enc);
    rv = exr_finish(&f);
    if (rc == 0 && rv != EXR_ERR_SUCCESS) rc = exr_fail(e, path, "finish", rv);
    if (rc == 0) {
        rt_out *o = rt_out_open(path, e);
        if (!o) rc = -1;
        else {
            rt_out_write(o, mem.p, mem.n); /* a short write keeps its reason (ENOSPC) */
            rc = rt_out_commit(o, e);      /* and fails here with it */
        }
    }
    free(mem.p);
    return rc;
}

rt_image *rt_exr_read(const char *path, rt_err *e)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet_handler;
    exr_context_t f = NULL;
    exr_decode_pipeline_t dec;
    int have_dec = 0;
    rt_image *im = NULL;
    exr_result_t rv;
    exr_last_msg[0] = 0;

    if ((rv = exr_start_read(&f, path, &init))) {
        exr_fail(e, path, "cannot read", rv);
        return NULL;
    }
    exr_attr_box2i_t dw;
    int32_t spc = 1;
    if ((rv = exr_get_data_window(f, 0, &dw)) || (rv = exr_get_scanlines_per_chunk(f, 0, &spc))) {
        exr_fail(e, path, "header", rv);
        goto fail;
    }
    im = rt_image_new(dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1, e);
    if (!im) goto fail;
    for (int y = 0; y < im->H; y += spc) {
        exr_chunk_info_t ci;
        if ((rv = exr_read_scanline_chunk_info(f, 0, y + dw.min.y, &ci))) {
            exr_fail(e, path, "chunk", rv);
            goto fail;
        }
        rv = have_dec ? exr_decoding_update(f, 0, &ci, &dec) : exr_decoding_initialize(f, 0, &ci, &dec);
        if (rv) {
            exr_fail(e, path, "decoder", rv);
            goto fail;
        }
        for (int c = 0; c < dec.channel_count; c++) {
            int stride, off;
            float *p = plane(im, dec.channels[c].channel_name, &stride, &off);
            if (!p || dec.channels[c].x_samples != 1 || dec.channels[c].y_samples != 1) {
                dec.channels[c].decode_to_ptr = NULL; /* skipped */
                continue;
            }
            dec.channels[c].user_pixel_stride = (int32_t)(stride * sizeof(float));
            dec.channels[c].user_line_stride = (int32_t)(stride * sizeof(float) * (size_t)im->W);
            dec.channels[c].user_bytes_per_element = sizeof(float);
            dec.channels[c].user_data_type = EXR_PIXEL_FLOAT;
            dec.channels[c].decode_to_ptr = (uint8_t *)(p + ((size_t)y * im->W) * stride + off);
        }
        if (!have_dec) {
            have_dec = 1;
            if ((rv = exr_decoding_choose_default_routines(f, 0, &dec))) {
                exr_fail(e, path, "decoder", rv);
                goto fail;
            }
        }
        if ((rv = exr_decoding_run(f, 0, &dec))) {
            exr_fail(e, path, "decode", rv);
            goto fail;
        }
    }
    exr_decoding_destroy(f, &dec);
    exr_finish(&f);
    return im;
fail:
    if (have_dec) exr_decoding_destroy(f, &dec);
    exr_finish(&f);
    rt_image_free(im);
    return NULL;
}
