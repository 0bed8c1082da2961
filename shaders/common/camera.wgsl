// The camera of RainParams: pixel → world ray, world → camera. Shared by every stage that
// looks along the picture's rays (the haze, the wet ground) or projects drops (the drops, the
// splashes); the CPU twins use `scene::Camera` and `gpu::cpu` helpers written from the method.

// World direction (not normalised; unit depth along the optical axis) of the ray through the
// centre of coded pixel p: coded → display (coded_from_display) → pinhole → world.
fn view_ray(p: vec2<u32>) -> vec3<f32> {
    let m = rain.coded_from_display;
    let c = vec2<f32>(p) + vec2<f32>(0.5) - rain.coded_offset_px;
    let q = vec2<f32>(m.x * c.x + m.y * c.y, m.z * c.x + m.w * c.y);
    let d = (q - rain.principal_px) / rain.focal_px;
    return rain.camera_from_world_0.xyz * d.x + rain.camera_from_world_1.xyz * d.y + rain.camera_from_world_2.xyz;
}

// As view_ray, through continuous coded position c (pixel p spans p to p + 1).
fn view_ray_at(c_px: vec2<f32>) -> vec3<f32> {
    let m = rain.coded_from_display;
    let c = c_px - rain.coded_offset_px;
    let q = vec2<f32>(m.x * c.x + m.y * c.y, m.z * c.x + m.w * c.y);
    let d = (q - rain.principal_px) / rain.focal_px;
    return rain.camera_from_world_0.xyz * d.x + rain.camera_from_world_1.xyz * d.y + rain.camera_from_world_2.xyz;
}

// A world point in the camera's frame (x right, y down, z forward, metres).
fn to_camera(p_world: vec3<f32>) -> vec3<f32> {
    let d = p_world - rain.camera_pos_m.xyz;
    return vec3<f32>(dot(rain.camera_from_world_0.xyz, d), dot(rain.camera_from_world_1.xyz, d), dot(rain.camera_from_world_2.xyz, d));
}

// The world offset from the camera of camera-space point `p_cam`: world_from_camera · p, the
// rows of camera_from_world.
fn world_offset(p_cam: vec3<f32>) -> vec3<f32> {
    return rain.camera_from_world_0.xyz * p_cam.x + rain.camera_from_world_1.xyz * p_cam.y + rain.camera_from_world_2.xyz * p_cam.z;
}
