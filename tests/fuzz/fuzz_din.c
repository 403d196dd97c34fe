/*
 * fuzz_din.c -- fuzz target for the Dinero IV din reader (src/din.c).
 *
 * Input: one byte choosing the record class (mod RT_NCLASS) and the read
 * buffer size (1..16, so batches end mid-file), then the din text.
 * Contracts checked: every record is 1 byte, of the class given at open,
 * write iff label 1; the end of file comes only after every byte was read
 * (rt_din_file_bytes == input size, rt_din_file_hash == FNV-1a of the
 * input); the number of records equals the number of non-blank lines; an
 * error has a message.
 */
#include "din.h"
#include "fuzz.h"

static size_t nonblank_lines(const uint8_t *p, size_t n)
{
    size_t lines = 0;
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && (p[j] == ' ' || p[j] == '\t')) j++;
        if (j < n && p[j] != '\n' && p[j] != '\r') lines++;
        while (j < n && p[j] != '\n') j++;
        i = j + 1;
    }
    return lines;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    int cls = data[0] % RT_NCLASS;
    size_t cap = 1 + (data[0] >> 4);
    const uint8_t *text = data + 1;
    size_t n = size - 1;
    const char *path = rt_fuzz_file(text, n);
    rt_err e = {0};
    rt_din *d = rt_din_open(path, cls, &e);
    if (!d) rt_fuzz_fail("open failed: %s", e.msg);
    rt_access buf[16];
    size_t recs = 0;
    long got;
    while ((got = rt_din_read(d, buf, cap, &e)) > 0) {
        if ((size_t)got > cap) rt_fuzz_fail("read %ld records into %zu", got, cap);
        for (long i = 0; i < got; i++)
            if (buf[i].size != 1 || buf[i].cls != cls || buf[i].write > 1)
                rt_fuzz_fail("record %zu: size %u class %u write %u", recs + (size_t)i, buf[i].size, buf[i].cls,
                             buf[i].write);
        recs += (size_t)got;
    }
    if (got < 0 && !e.msg[0]) rt_fuzz_fail("error without a message");
    if (got == 0) {
        if (rt_din_file_bytes(d) != n) rt_fuzz_fail("end after %llu of %zu bytes",
                                                     (unsigned long long)rt_din_file_bytes(d), n);
        if (rt_din_file_hash(d) != rt_fnv1a(RT_FNV_INIT, text, n)) rt_fuzz_fail("hash differs");
        if (recs != nonblank_lines(text, n)) rt_fuzz_fail("%zu records, %zu non-blank lines", recs,
                                                          nonblank_lines(text, n));
        if (rt_din_read(d, buf, cap, &e) != 0) rt_fuzz_fail("read after the end is not 0");
        rt_fuzz_accepted = 1;
    }
    rt_din_close(d);
    return 0;
}
