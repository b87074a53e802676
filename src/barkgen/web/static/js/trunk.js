// 3D trunk preview: the result's material set on a displaced cylinder, in
// metres, as barkgen.render.trunk_mesh makes the glb: a set of known real size
// goes round the trunk at its real width (the repeats rounded to a whole
// number) and its relief is its depth in metres; the Depth slider scales it,
// the Photo light slider relights the colour in the shader with the photo's
// broad light L (colour_linear * L^(set's - chosen), as MaterialSet.relit_color).
//
// This module imports three.js statically; result.js loads it with a dynamic
// import() so a missing three.js (or no WebGL) only disables this panel.

import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

/** The trunk's radius in metres (barkgen.render.trunk_mesh's default) and height. */
const RADIUS = 0.15;
const HEIGHT = 4 * RADIUS;
const SEGMENTS = 256;
/** The gain the relit colour is capped at either way (barkgen.material.illumination.MAX_GAIN). */
const MAX_GAIN = 8;

/** Times a set `widthM` metres wide goes round the trunk at its real size (barkgen.render.real_repeat). */
export function realRepeat(widthM) {
  return Math.max(1, Math.round((2 * Math.PI * RADIUS) / widthM));
}

/** The depth multiplier of the Depth slider (log2 of it on the slider). */
export function reliefOf(input) {
  return Math.round(2 ** Number(input.value) * 1e4) / 1e4;
}

/** The photo light taken out of the colour, 0..1, of the Photo light slider (percent). */
export function lightOf(input) {
  return Number(input.value) / 100;
}

/**
 * Light direction from azimuth/elevation in degrees. y is up (the trunk's
 * axis); azimuth 0 = from the viewer's side at the start (+z), 90 = from the right.
 */
function lightDirection(azimuthDeg, elevationDeg) {
  const az = THREE.MathUtils.degToRad(azimuthDeg);
  const el = THREE.MathUtils.degToRad(elevationDeg);
  return new THREE.Vector3(Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az));
}

/** Load a texture; resolves null for a missing URL. */
function loadTexture(loader, url, colour) {
  if (!url) return Promise.resolve(null);
  return loader.loadAsync(url).catch(() => {
    // the loader rejects with a DOM Event: turn it into a readable error
    throw new Error(`could not load ${url}`);
  }).then((texture) => {
    texture.wrapS = THREE.RepeatWrapping;
    texture.wrapT = THREE.RepeatWrapping;
    texture.colorSpace = colour ? THREE.SRGBColorSpace : THREE.NoColorSpace;
    texture.anisotropy = 8;
    return texture;
  });
}

/**
 * Normal (OpenGL, 8-bit RGBA) and displacement (8-bit, `low`..`high` to 0..255)
 * texel data of a height field in pixels, rows flipped to the bottom-up order a
 * DataTexture reads (an image texture is flipped on upload, a DataTexture not).
 */
function reliefTexels(height, width, rows, tile, low, high) {
  const normal = new Uint8Array(width * rows * 4);
  const disp = new Uint8Array(width * rows * 4);
  const span = high > low ? 255 / (high - low) : 0;
  const at = (x, y) => height[y * width + x];
  for (let y = 0; y < rows; y++) {
    const up = y > 0 ? y - 1 : tile ? rows - 1 : 0;
    const down = y < rows - 1 ? y + 1 : tile ? 0 : rows - 1;
    const out = (rows - 1 - y) * width * 4;
    for (let x = 0; x < width; x++) {
      const left = x > 0 ? x - 1 : tile ? width - 1 : 0;
      const right = x < width - 1 ? x + 1 : tile ? 0 : width - 1;
      // central differences (wrapping when the set tiles), one-sided at other borders
      const gx = (at(right, y) - at(left, y)) * (tile || (x > 0 && x < width - 1) ? 0.5 : 1);
      const gy = (at(x, down) - at(x, up)) * (tile || (y > 0 && y < rows - 1) ? 0.5 : 1);
      // OpenGL: x right, y up (rows run down), z out
      const nx = -gx;
      const ny = gy;
      const inv = 1 / Math.sqrt(nx * nx + ny * ny + 1);
      const i = out + x * 4;
      normal[i] = Math.round((nx * inv * 0.5 + 0.5) * 255);
      normal[i + 1] = Math.round((ny * inv * 0.5 + 0.5) * 255);
      normal[i + 2] = Math.round((inv * 0.5 + 0.5) * 255);
      normal[i + 3] = 255;
      const d = Math.max(0, Math.min(255, Math.round((at(x, y) - low) * span)));
      disp[i] = d;
      disp[i + 1] = d;
      disp[i + 2] = d;
      disp[i + 3] = 255;
    }
  }
  return { normal, disp };
}

function dataTexture(data, width, rows) {
  const texture = new THREE.DataTexture(data, width, rows, THREE.RGBAFormat);
  texture.wrapS = THREE.RepeatWrapping;
  texture.wrapT = THREE.RepeatWrapping;
  texture.colorSpace = THREE.NoColorSpace;
  texture.magFilter = THREE.LinearFilter;
  texture.minFilter = THREE.LinearMipmapLinearFilter;
  texture.generateMipmaps = true;
  texture.anisotropy = 8;
  texture.needsUpdate = true;
  return texture;
}

/**
 * The photo's light as a half-float texture of log2 L, rows bottom-up (a
 * DataTexture is not flipped on upload), wrapping as the maps do.
 */
function lightTexture(light, width, rows) {
  const data = new Uint16Array(width * rows);
  for (let y = 0; y < rows; y++) {
    const from = y * width;
    const to = (rows - 1 - y) * width;
    for (let x = 0; x < width; x++) data[to + x] = THREE.DataUtils.toHalfFloat(Math.log2(light[from + x]));
  }
  const texture = new THREE.DataTexture(data, width, rows, THREE.RedFormat, THREE.HalfFloatType);
  texture.wrapS = THREE.RepeatWrapping;
  texture.wrapT = THREE.RepeatWrapping;
  texture.colorSpace = THREE.NoColorSpace;
  texture.magFilter = THREE.LinearFilter;
  texture.minFilter = THREE.LinearFilter;
  texture.generateMipmaps = false;
  texture.needsUpdate = true;
  return texture;
}

/**
 * The material relights its colour (after the colour map's sRGB decoding, in
 * linear light) by clamp(L^power, 1/8, 8), L sampled where the colour is.
 */
function relightInShader(material, uniforms) {
  material.onBeforeCompile = (shader) => {
    shader.uniforms.photoLight = uniforms.photoLight;
    shader.uniforms.photoLightPower = uniforms.photoLightPower;
    shader.fragmentShader = shader.fragmentShader
      .replace("#include <common>", "#include <common>\nuniform sampler2D photoLight;\nuniform float photoLightPower;")
      .replace(
        "#include <map_fragment>",
        `#include <map_fragment>
        #ifdef USE_MAP
          float photoGain = clamp(exp2(texture2D(photoLight, vMapUv).r * photoLightPower), ${(1 / MAX_GAIN).toFixed(6)}, ${MAX_GAIN.toFixed(1)});
          diffuseColor.rgb = min(diffuseColor.rgb * photoGain, vec3(1.0));
        #endif`
      );
  };
  material.customProgramCacheKey = () => "barkgen-photo-light";
}

/**
 * Set up the trunk viewer.
 * @param {object} opts
 * @param {HTMLCanvasElement} opts.canvas
 * @param {object} opts.result   GET /api/results/{id} answer
 * @param {object} opts.controls {azimuth, elevation, repeat, depth, light} range inputs
 * @param {Promise<?{light: Float32Array, width: number, rows: number}>} opts.illumination
 *   the photo's light carried to the result (null: none)
 * @param {(text:string)=>void} opts.onStatus  short messages for the panel
 * @returns {Promise<{dispose: Function}>}
 */
export async function initTrunk({ canvas, result, controls, illumination, onStatus }) {
  // Throws when WebGL is unavailable; the caller shows a message.
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.outputColorSpace = THREE.SRGBColorSpace;

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1a1b1d);

  const camera = new THREE.PerspectiveCamera(35, 1, 0.05 * RADIUS, 100 * RADIUS);
  camera.position.set(0, 0.3 * RADIUS, 5.2 * RADIUS);

  const orbit = new OrbitControls(camera, canvas);
  orbit.target.set(0, 0, 0);
  orbit.enableDamping = false; // render on demand: no inertia animation
  orbit.minDistance = 1.6 * RADIUS;
  orbit.maxDistance = 14 * RADIUS;
  // keep the view on the bark: no looking down into the open tube
  orbit.minPolarAngle = Math.PI / 2 - 0.6;
  orbit.maxPolarAngle = Math.PI / 2 + 0.6;
  const home = { position: camera.position.clone(), target: orbit.target.clone() };
  orbit.update();

  const sun = new THREE.DirectionalLight(0xffffff, 3.0);
  scene.add(sun);
  scene.add(new THREE.AmbientLight(0xffffff, 0.35));

  // Open-ended cylinder. The aoMap uses texture channel 0 (the `uv`
  // attribute) by default; a uv1 copy also serves a second-channel set-up.
  const geometry = new THREE.CylinderGeometry(RADIUS, RADIUS, HEIGHT, SEGMENTS, SEGMENTS, true);
  geometry.setAttribute("uv1", geometry.attributes.uv);

  // --- textures --------------------------------------------------------------
  onStatus("Loading textures…");
  const maps = result.maps || null;
  const colourUrl = (maps && maps.Color) || (result.files && result.files["texture.png"]);
  if (!colourUrl) throw new Error("This result has no texture to show.");
  const loader = new THREE.TextureLoader();
  const colourLoaded = loadTexture(loader, colourUrl, true).catch((err) => {
    renderer.dispose(); // free the WebGL context: the page will not use it
    throw err;
  });
  const [colour, normal, displacement, ao, roughness] = await Promise.all([
    colourLoaded,
    loadTexture(loader, maps && maps.NormalGL).catch(() => null),
    loadTexture(loader, maps && maps.Displacement).catch(() => null),
    loadTexture(loader, maps && maps.AmbientOcclusion).catch(() => null),
    loadTexture(loader, maps && maps.Roughness).catch(() => null),
  ]);
  const textures = [colour, normal, displacement, ao, roughness].filter(Boolean);

  const material = new THREE.MeshStandardMaterial({
    map: colour,
    normalMap: normal,
    displacementMap: displacement,
    aoMap: ao,
    roughnessMap: roughness,
    roughness: roughness ? 1.0 : 0.85,
    metalness: 0.0,
  });
  // the photo's light: none (L = 1) until it has loaded
  const uniforms = {
    photoLight: { value: lightTexture(new Float32Array([1]), 1, 1) },
    photoLightPower: { value: 0 },
  };
  relightInShader(material, uniforms);
  const trunk = new THREE.Mesh(geometry, material);
  scene.add(trunk);

  // Texel aspect of the texture (width / height), and the set's record.
  const image = colour.image;
  const texWidth = (image && image.width) || 1;
  const aspect = image && image.width && image.height ? image.width / image.height : 1;
  const record = result.material || null;
  const widthM = record && record.width_m ? Number(record.width_m) : null;
  // the height's range in px (the displacement map's 0..1), the set's own until the editor's
  const depthPx = record ? Number(record.displacement_depth_px) || 0 : 0;
  const midlevel = Number((record && record.displacement_midlevel) ?? 0.5);
  let range = [-midlevel * depthPx, (1 - midlevel) * depthPx];
  const setLight = Number((record && record.light_equalization) ?? 1);
  if (widthM) {
    // at its real size the texture goes round as many whole times as fit
    const repeat = realRepeat(widthM);
    controls.repeat.max = String(Math.max(Number(controls.repeat.max), repeat));
    controls.repeat.value = String(repeat);
    controls.repeat.disabled = true;
    controls.repeat.title = `The set is ${Math.round(widthM * 1000)} mm wide: at its real size it goes ${repeat}× round this trunk (${Math.round(RADIUS * 2000)} mm across).`;
    controls.repeat.dispatchEvent(new Event("input"));
  }

  // --- controls --------------------------------------------------------------
  const repeatNow = () => (widthM ? realRepeat(widthM) : Math.max(1, Number(controls.repeat.value) || 1));
  const apply = () => {
    const az = Number(controls.azimuth.value);
    const el = Number(controls.elevation.value);
    sun.position.copy(lightDirection(az, el).multiplyScalar(10));

    // u: `repeat` times round the trunk; v: as many as keep the texels square.
    const repeat = repeatNow();
    const circumference = 2 * Math.PI * RADIUS;
    const repeatV = (HEIGHT * repeat * aspect) / circumference;
    for (const texture of textures) texture.repeat.set(repeat, repeatV);

    // Relief in metres: the height times the pixel's size (the set's real one, else
    // a texel's width on the trunk), times Depth; height 0 on the trunk's radius.
    // The normals' slopes scale with it (normalScale is exact for a height's slopes).
    const relief = material.displacementMap ? reliefOf(controls.depth) : 0;
    const metresPerPx = widthM ? widthM / texWidth : circumference / repeat / texWidth;
    material.displacementScale = (range[1] - range[0]) * metresPerPx * relief;
    material.displacementBias = range[0] * metresPerPx * relief;
    material.normalScale.set(relief || 1, relief || 1);

    // Photo light: the colour as if `chosen` of the light were out instead of the set's
    uniforms.photoLightPower.value = controls.light.disabled ? 0 : setLight - lightOf(controls.light);
  };

  const resize = () => {
    const width = canvas.clientWidth || 480;
    const height = canvas.clientHeight || 360;
    renderer.setSize(width, height, false);
    camera.aspect = width / height;
    camera.updateProjectionMatrix();
  };

  let pending = false;
  let frames = 0;
  const render = () => {
    pending = false;
    renderer.render(scene, camera);
    canvas.dataset.frames = String(++frames);
  };
  const requestRender = () => {
    if (pending) return;
    pending = true;
    requestAnimationFrame(render);
  };

  orbit.addEventListener("change", requestRender);
  const onInput = () => {
    apply();
    requestRender();
  };
  for (const input of [controls.azimuth, controls.elevation, controls.repeat, controls.depth, controls.light]) {
    input.addEventListener("input", onInput);
    input.addEventListener("change", onInput);
  }
  if (controls.reset) {
    controls.reset.addEventListener("click", () => {
      camera.position.copy(home.position);
      orbit.target.copy(home.target);
      orbit.update();
      requestRender();
    });
  }
  const observer = new ResizeObserver(() => {
    resize();
    requestRender();
  });
  observer.observe(canvas);

  // Say when displacement is not available (no material maps).
  if (!displacement) controls.depth.disabled = true;

  // --- first frame -------------------------------------------------------------
  resize();
  apply();
  render();
  canvas.dataset.ready = "1";
  onStatus("");

  // The photo's light, once it has come (the slider waits for it).
  illumination
    .then((answer) => {
      if (!answer) return;
      const old = uniforms.photoLight.value;
      uniforms.photoLight.value = lightTexture(answer.light, answer.width, answer.rows);
      old.dispose();
      textures.push(uniforms.photoLight.value);
      apply();
      requestRender();
    })
    .catch(() => {}); // the page says why the slider stays off

  // The relief editor's heights: normals and displacement made here, the first
  // height's range mapped to the displacement's 0..1 (as the set's own map).
  let edited = null; // {normal, disp}: the editor's textures, made once and refilled
  let ranged = false;
  const setRelief = (height, width, rows, tile) => {
    if (!ranged) {
      let low = Infinity;
      let high = -Infinity;
      for (const v of height) {
        if (v < low) low = v;
        if (v > high) high = v;
      }
      range = [low, high];
      ranged = true;
    }
    const { normal: normalData, disp } = reliefTexels(height, width, rows, tile, range[0], range[1]);
    if (!edited || edited.normal.image.width !== width || edited.normal.image.height !== rows) {
      for (const old of [material.normalMap, material.displacementMap]) {
        if (!old) continue;
        old.dispose();
        textures.splice(textures.indexOf(old), 1);
      }
      edited = { normal: dataTexture(normalData, width, rows), disp: dataTexture(disp, width, rows) };
      material.normalMap = edited.normal;
      material.displacementMap = edited.disp;
      textures.push(edited.normal, edited.disp);
      material.needsUpdate = true;
      controls.depth.disabled = false;
    } else {
      edited.normal.image.data = normalData;
      edited.disp.image.data = disp;
      edited.normal.needsUpdate = true;
      edited.disp.needsUpdate = true;
    }
    apply();
    render(); // now: the caller times the edit up to this frame
  };

  return {
    render: requestRender,
    setRelief,
    /** Frames drawn so far (a test's proof that a slider re-rendered). */
    get frames() {
      return frames;
    },
    dispose() {
      observer.disconnect();
      orbit.dispose();
      geometry.dispose();
      material.dispose();
      textures.forEach((t) => t.dispose());
      renderer.dispose();
    },
  };
}
