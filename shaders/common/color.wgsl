// Transfer functions and YCbCr matrices: the GPU twin of src/video/color.rs. Odd-extended to
// negative values and never clamped, so a frame without rain survives the round trip.

const BT709_ALPHA: f32 = 1.0992968;
const BT709_BETA: f32 = 0.018053968;
const PQ_M1: f32 = 0.1593017578125;
const PQ_M2: f32 = 78.84375;
const PQ_C1: f32 = 0.8359375;
const PQ_C2: f32 = 18.8515625;
const PQ_C3: f32 = 18.6875;
const PQ_PEAK_OVER_WHITE: f32 = 49.26108374;
const HLG_A: f32 = 0.17883277;
const HLG_B: f32 = 0.28466892;
const HLG_C: f32 = 0.55991073;
// HLG's reference white as scene light (75 % signal, BT.2408): diffuse white is 1.0.
const HLG_REF_WHITE: f32 = 0.26496256;

fn to_linear_abs(t: u32, e: f32) -> f32 {
    switch t {
        case 0u: {
            if e < 4.5 * BT709_BETA { return e / 4.5; }
            return pow((e + BT709_ALPHA - 1.0) / BT709_ALPHA, 1.0 / 0.45);
        }
        case 1u: {
            if e <= 0.04045 { return e / 12.92; }
            return pow((e + 0.055) / 1.055, 2.4);
        }
        case 2u: { return pow(e, 2.2); }
        case 3u: { return pow(e, 2.8); }
        case 5u: {
            let p = pow(e, 1.0 / PQ_M2);
            let num = max(p - PQ_C1, 0.0);
            return pow(num / (PQ_C2 - PQ_C3 * p), 1.0 / PQ_M1) * PQ_PEAK_OVER_WHITE;
        }
        case 6u: {
            if e <= 0.5 { return e * e / (3.0 * HLG_REF_WHITE); }
            return (exp((e - HLG_C) / HLG_A) + HLG_B) / (12.0 * HLG_REF_WHITE);
        }
        default: { return e; }
    }
}

fn from_linear_abs(t: u32, l: f32) -> f32 {
    switch t {
        case 0u: {
            if l < BT709_BETA { return 4.5 * l; }
            return BT709_ALPHA * pow(l, 0.45) - (BT709_ALPHA - 1.0);
        }
        case 1u: {
            if l <= 0.0031308 { return 12.92 * l; }
            return 1.055 * pow(l, 1.0 / 2.4) - 0.055;
        }
        case 2u: { return pow(l, 1.0 / 2.2); }
        case 3u: { return pow(l, 1.0 / 2.8); }
        case 5u: {
            let y = pow(l / PQ_PEAK_OVER_WHITE, PQ_M1);
            return pow((PQ_C1 + PQ_C2 * y) / (1.0 + PQ_C3 * y), PQ_M2);
        }
        case 6u: {
            let scene = l * HLG_REF_WHITE;
            if scene <= 1.0 / 12.0 { return sqrt(3.0 * scene); }
            return HLG_A * log(12.0 * scene - HLG_B) + HLG_C;
        }
        default: { return l; }
    }
}

fn to_linear(t: u32, e: vec3<f32>) -> vec3<f32> {
    return sign(e) * vec3<f32>(to_linear_abs(t, abs(e.x)), to_linear_abs(t, abs(e.y)), to_linear_abs(t, abs(e.z)));
}

fn from_linear(t: u32, l: vec3<f32>) -> vec3<f32> {
    return sign(l) * vec3<f32>(from_linear_abs(t, abs(l.x)), from_linear_abs(t, abs(l.y)), from_linear_abs(t, abs(l.z)));
}

// Normalised Y'CbCr (Y' in [0,1], C in [−½,½]) → R'G'B'.
fn ycbcr_to_rgb(kr: f32, kb: f32, ycc: vec3<f32>) -> vec3<f32> {
    let r = ycc.x + 2.0 * (1.0 - kr) * ycc.z;
    let b = ycc.x + 2.0 * (1.0 - kb) * ycc.y;
    let g = (ycc.x - kr * r - kb * b) / (1.0 - kr - kb);
    return vec3<f32>(r, g, b);
}

// R'G'B' → normalised Y'CbCr.
fn rgb_to_ycbcr(kr: f32, kb: f32, rgb: vec3<f32>) -> vec3<f32> {
    let y = kr * rgb.x + (1.0 - kr - kb) * rgb.y + kb * rgb.z;
    return vec3<f32>(y, (rgb.z - y) / (2.0 * (1.0 - kb)), (rgb.x - y) / (2.0 * (1.0 - kr)));
}
