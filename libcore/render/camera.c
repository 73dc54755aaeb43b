/* The pinhole camera: fitting to a box, the JSON form, and the OpenGL view and projection
 * matrices (gluLookAt / gluPerspective conventions). */
#include <pf/render.h>

#include <stdlib.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

/* A unit vector perpendicular to the unit vector up: +x made orthogonal to it, or +y when up is
 * close to x. */
static pf_vec3 perpendicular(pf_vec3 up)
{
    pf_vec3 a = fabs(up.x) < 0.9 ? pf_v3(1, 0, 0) : pf_v3(0, 1, 0);
    return pf_v3_normalize(pf_v3_sub(a, pf_v3_scale(up, pf_v3_dot(a, up))));
}

/* Each corner p of the box must satisfy |lateral offset| <= tan(half angle) * margin * depth, where
 * depth = D - (p - target) . back along the view axis; the smallest distance D is the largest of
 * these lower bounds over the corners and the two image axes. */
pf_camera pf_camera_fit(pf_vec3 lo, pf_vec3 hi, pf_vec3 up, double fov_deg, double aspect,
                        double margin)
{
    up = pf_v3_normalize(up);
    if (pf_v3_norm(up) == 0)
        up = pf_v3(0, 0, 1);
    pf_vec3 e1 = perpendicular(up), e2 = pf_v3_cross(up, e1);
    double az = -60 * PI / 180, el = 25 * PI / 180;
    pf_vec3 back = pf_v3_add(
        pf_v3_scale(pf_v3_add(pf_v3_scale(e1, cos(az)), pf_v3_scale(e2, sin(az))), cos(el)),
        pf_v3_scale(up, sin(el)));
    pf_vec3 right = pf_v3_normalize(pf_v3_cross(pf_v3_scale(back, -1), up));
    pf_vec3 upv = pf_v3_cross(right, pf_v3_scale(back, -1));
    pf_vec3 c = pf_v3_scale(pf_v3_add(lo, hi), 0.5);
    double size = pf_v3_dist(lo, hi);
    if (!(size > 0) || !isfinite(size))
        size = 1;
    double ty = tan(0.5 * fov_deg * PI / 180) * margin, tx = ty * aspect;
    double dist = 0.01 * size;
    for (int k = 0; k < 8; ++k) {
        pf_vec3 p = pf_v3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
        pf_vec3 r = pf_v3_sub(p, c);
        double z = pf_v3_dot(r, back);
        dist = fmax(dist, z + fabs(pf_v3_dot(r, right)) / tx);
        dist = fmax(dist, z + fabs(pf_v3_dot(r, upv)) / ty);
        dist = fmax(dist, z + 0.01 * size);
    }
    return (pf_camera){
        .eye = pf_v3_add(c, pf_v3_scale(back, dist)), .target = c, .up = up, .fov_deg = fov_deg};
}

pf_status pf_camera_check(const pf_camera *cam, pf_error *err)
{
    PF_CHECK(pf_v3_isfinite(cam->eye) && pf_v3_isfinite(cam->target) && pf_v3_isfinite(cam->up),
             err, PF_ERR_INVALID, "camera: eye, target and up must be finite");
    pf_vec3 f = pf_v3_sub(cam->target, cam->eye);
    double fl = pf_v3_norm(f), ul = pf_v3_norm(cam->up);
    PF_CHECK(fl > 0, err, PF_ERR_INVALID, "camera: eye and target coincide");
    PF_CHECK(ul > 0, err, PF_ERR_INVALID, "camera: up is the zero vector");
    PF_CHECK(pf_v3_norm(pf_v3_cross(f, cam->up)) > 1e-6 * fl * ul, err, PF_ERR_INVALID,
             "camera: up is parallel to the view direction");
    PF_CHECK(cam->fov_deg > 0 && cam->fov_deg < 180, err, PF_ERR_INVALID,
             "camera: fov must lie in (0, 180) degrees, got %g", cam->fov_deg);
    return PF_OK;
}

void pf_camera_matrices(const pf_camera *cam, double aspect, double near_z, double far_z,
                        double view[16], double proj[16])
{
    pf_vec3 f = pf_v3_normalize(pf_v3_sub(cam->target, cam->eye));
    pf_vec3 s = pf_v3_normalize(pf_v3_cross(f, cam->up));
    pf_vec3 u = pf_v3_cross(s, f);
    double rows[3][3] = {{s.x, s.y, s.z}, {u.x, u.y, u.z}, {-f.x, -f.y, -f.z}};
    memset(view, 0, 16 * sizeof *view);
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            view[4 * c + r] = rows[r][c];
        view[12 + r] =
            -(rows[r][0] * cam->eye.x + rows[r][1] * cam->eye.y + rows[r][2] * cam->eye.z);
    }
    view[15] = 1;
    double t = 1 / tan(0.5 * cam->fov_deg * PI / 180);
    memset(proj, 0, 16 * sizeof *proj);
    proj[0] = t / aspect;
    proj[5] = t;
    proj[10] = (far_z + near_z) / (near_z - far_z);
    proj[11] = -1;
    proj[14] = 2 * far_z * near_z / (near_z - far_z);
}

/* ---- JSON ------------------------------------------------------------------------------------ */

/* The one object a camera is, parsed strictly: {"eye": [3], "target": [3], "up": [3], "fov": n}. */

typedef struct json_in {
    const char *text, *p;
} json_in;

static void skip_ws(json_in *in)
{
    while (*in->p == ' ' || *in->p == '\t' || *in->p == '\n' || *in->p == '\r')
        ++in->p;
}

static pf_status expect(json_in *in, char c, pf_error *err)
{
    skip_ws(in);
    PF_CHECK(*in->p == c, err, PF_ERR_FORMAT, "camera JSON: expected '%c' at offset %ld", c,
             (long)(in->p - in->text));
    ++in->p;
    return PF_OK;
}

static pf_status parse_number(json_in *in, double *v, pf_error *err)
{
    skip_ws(in);
    const char *start = in->p;
    while (strchr("+-0123456789.eE", *in->p) && *in->p)
        ++in->p;
    char buf[64];
    size_t n = (size_t)(in->p - start);
    PF_CHECK(n > 0 && n < sizeof buf, err, PF_ERR_FORMAT,
             "camera JSON: expected a number at offset %ld", (long)(start - in->text));
    memcpy(buf, start, n);
    buf[n] = '\0';
    char *end = NULL;
    *v = strtod(buf, &end);
    PF_CHECK(end == buf + n && isfinite(*v), err, PF_ERR_FORMAT,
             "camera JSON: bad number '%s' at offset %ld", buf, (long)(start - in->text));
    return PF_OK;
}

static pf_status parse_vec3(json_in *in, pf_vec3 *v, pf_error *err)
{
    double a[3];
    PF_TRY(expect(in, '[', err));
    for (int i = 0; i < 3; ++i) {
        PF_TRY(parse_number(in, &a[i], err));
        PF_TRY(expect(in, i < 2 ? ',' : ']', err));
    }
    *v = pf_v3_load(a);
    return PF_OK;
}

static pf_status parse_key(json_in *in, char *key, size_t cap, pf_error *err)
{
    PF_TRY(expect(in, '"', err));
    size_t n = 0;
    while (*in->p && *in->p != '"' && *in->p != '\\' && n + 1 < cap)
        key[n++] = *in->p++;
    key[n] = '\0';
    PF_CHECK(*in->p == '"', err, PF_ERR_FORMAT, "camera JSON: bad key at offset %ld",
             (long)(in->p - in->text));
    ++in->p;
    return expect(in, ':', err);
}

enum { KEY_EYE = 1, KEY_TARGET = 2, KEY_UP = 4, KEY_FOV = 8 };

static pf_status parse_member(json_in *in, pf_camera *cam, unsigned *seen, pf_error *err)
{
    char key[16];
    PF_TRY(parse_key(in, key, sizeof key, err));
    static const char *const NAMES[] = {"eye", "target", "up", "fov"};
    unsigned bit = 0;
    for (unsigned i = 0; i < 4; ++i)
        if (strcmp(key, NAMES[i]) == 0)
            bit = 1u << i;
    PF_CHECK(bit, err, PF_ERR_FORMAT, "camera JSON: unknown key \"%s\" (eye, target, up, fov)",
             key);
    PF_CHECK(!(*seen & bit), err, PF_ERR_FORMAT, "camera JSON: key \"%s\" given twice", key);
    *seen |= bit;
    if (bit == KEY_EYE)
        return parse_vec3(in, &cam->eye, err);
    if (bit == KEY_TARGET)
        return parse_vec3(in, &cam->target, err);
    if (bit == KEY_UP)
        return parse_vec3(in, &cam->up, err);
    return parse_number(in, &cam->fov_deg, err);
}

pf_status pf_camera_parse_json(const char *text, pf_camera *cam, pf_error *err)
{
    json_in in = {text, text};
    pf_camera c = {.up = pf_v3(0, 0, 1), .fov_deg = 40};
    unsigned seen = 0;
    PF_TRY(expect(&in, '{', err));
    skip_ws(&in);
    if (*in.p != '}') {
        for (;;) {
            PF_TRY(parse_member(&in, &c, &seen, err));
            skip_ws(&in);
            if (*in.p == '}')
                break;
            PF_TRY(expect(&in, ',', err));
        }
    }
    ++in.p;
    skip_ws(&in);
    PF_CHECK(*in.p == '\0', err, PF_ERR_FORMAT, "camera JSON: unexpected text at offset %ld",
             (long)(in.p - text));
    PF_CHECK((seen & (KEY_EYE | KEY_TARGET)) == (KEY_EYE | KEY_TARGET), err, PF_ERR_FORMAT,
             "camera JSON: \"eye\" and \"target\" are required");
    PF_TRY(pf_camera_check(&c, err));
    *cam = c;
    return PF_OK;
}
