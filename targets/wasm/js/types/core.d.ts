/** A 3-vector: [x, y, z] (any array-like) or three.js's Vector3. */
export type Vec3Like = ArrayLike<number> | { x: number; y: number; z: number };

export interface SceneOptions {
  /**
   * Watertight mode: Woop, Benthin & Wald's watertight triangle test and a conservative walk,
   * so no ray slips between triangles sharing an edge; intersectAll/crossings are exact on shared
   * edges and vertices. A little slower than the default (Möller–Trumbore).
   */
  watertight?: boolean;
  /**
   * 'wide' (the default) also stores the tree as eight-wide nodes with tight boxes, which single
   * rays walk faster; 'nodes' keeps the binary nodes only (a smaller tree).
   */
  layout?: 'wide' | 'nodes';
  /**
   * How a leaf holds its triangles: 'list' (the default) as indices into one triangle array,
   * which the walk gathers four at a time into one SIMD test; 'groups' copied inline, four to a
   * group — single rays faster, two to four times the memory. Both are built with the SAH priced
   * in groups (Scene.build only: a loaded .kdt keeps its own).
   */
  leaves?: 'groups' | 'list';
  /**
   * The builder: 'fast' (the default) picks planes from bins on all but the smallest nodes and
   * lets a triangle be referenced at most twice over along a path, past the depth limit only
   * nodes of more than 32 triangles splitting, as `kdray build --quality fast` does: the build for a first answer; 'high'
   * sweeps every candidate plane exactly at every node, every level (`--quality high`): a build
   * several times slower of a tree that traces faster, for many millions of rays. Both make
   * valid trees of the same format (Scene.build only: a loaded .kdt keeps its own).
   */
  quality?: 'fast' | 'high';
}

export interface Hit {
  /** t along the ray: origin + distance·direction is the point (a distance for a unit direction). */
  distance: number;
  /** The triangle: its index in the input (indices / 3, or positions / 9 without indices). */
  faceIndex: number;
  point: [number, number, number];
  /** Barycentric weights of the triangle's second and third vertices. */
  u: number;
  v: number;
}

export interface AllHit extends Hit {
  /** +1 where the triangle's front (counter-clockwise) side faces the ray's origin, else −1. */
  facing: 1 | -1;
}

export interface SceneInfo {
  triangles: number;
  nodes: number;
  depth: number;
  bounds: { min: [number, number, number]; max: [number, number, number] };
  simd128: boolean;
}

/**
 * Indices, 3 a triangle: typed, an Array of vertex numbers, or a three.js BufferAttribute
 * (`geometry.index`; its itemSize must be 1, checked at run time: three.js types it `number`).
 */
export type Indices = Uint32Array | Uint16Array | ArrayLike<number> | { isBufferAttribute: true; array: ArrayLike<number>; count: number; itemSize: number };

/** Scene.fromBytes's options: a .kdt keeps its own layout and leaves. */
export interface LoadOptions {
  watertight?: boolean;
}

export declare class Scene {
  /** Builds the SAH kd-tree of a mesh: positions 3 floats a vertex; without indices every 9 floats are a triangle. */
  static build(positions: Float32Array, indices?: Indices | null, options?: SceneOptions): Promise<Scene>;
  static build(positions: Float32Array, options?: SceneOptions): Promise<Scene>;
  /** Scene.build, synchronously (the default entry compiles the module on first use; kdray/core needs `await init(source)` first). */
  static buildSync(positions: Float32Array, indices?: Indices | null, options?: SceneOptions): Scene;
  /** A scene from a .kdt's bytes (`kdray build`, or `scene.toBytes()`). */
  static fromBytes(bytes: Uint8Array | ArrayBuffer, options?: LoadOptions): Promise<Scene>;
  static fromBytesSync(bytes: Uint8Array | ArrayBuffer, options?: LoadOptions): Scene;
  /** The .kdt bytes (a copy). */
  toBytes(): Uint8Array;
  /** Frees the tree; the scene cannot be used afterwards. */
  dispose(): void;
  readonly watertight: boolean;
  readonly info: SceneInfo;
  /** The closest hit with near < t < far, or null. */
  raycast(origin: Vec3Like, direction: Vec3Like, near?: number, far?: number): Hit | null;
  /** Whether anything lies along the ray with near < t < far. */
  occluded(origin: Vec3Like, direction: Vec3Like, near?: number, far?: number): boolean;
  /**
   * Closest hits of many rays: `rays` 8 floats a ray (ox, oy, oz, dx, dy, dz, near, far);
   * returns 4 floats a ray (t, face index as u32 bits, u, v; a miss is t = Infinity, face
   * 0xFFFFFFFF), into `hits` when given (no allocation per call for the same hits and count).
   */
  raycastMany(rays: Float32Array, hits?: Float32Array): Float32Array;
  /** Every hit along the ray, nearest first. */
  intersectAll(origin: Vec3Like, direction: Vec3Like, near?: number, far?: number): AllHit[];
  /** The number of hits intersectAll would return. */
  crossings(origin: Vec3Like, direction: Vec3Like, near?: number, far?: number): number;
  /** Whether a point is inside the closed mesh (parity of a watertight ray's crossings). */
  contains(point: Vec3Like): boolean;
}

/** A hit of InstancedScene.raycast. */
export interface InstanceHit extends Hit {
  /** The instance's id (setInstances' `ids`, or its index there). */
  id: number;
  /** The unit geometric normal of the triangle as placed (its counter-clockwise side). */
  normal: [number, number, number];
}

/** InstancedScene.setInstances' argument. */
export interface Instances {
  /** Each instance's mesh: an index into the constructor's array. */
  meshes: ArrayLike<number>;
  /** 12 numbers an instance: the object → world 3×4 matrix, row by row (m00 m01 m02 tx, …). */
  transforms: ArrayLike<number>;
  /** Each instance's id, a u32 (default: its index). */
  ids?: ArrayLike<number> | null;
}

export interface InstancedSceneInfo {
  instances: number;
  nodes: number;
  depth: number;
  bounds: { min: [number, number, number]; max: [number, number, number] };
}

/** A scene of many meshes: instances of Scenes placed by affine transforms, with ids. */
export declare class InstancedScene {
  constructor(meshes: Scene[], options?: LoadOptions);
  readonly watertight: boolean;
  readonly meshes: Scene[];
  readonly info: InstancedSceneInfo;
  /** Places the instances (the top level is built again); returns how many were placed. */
  setInstances(instances: Instances): number;
  /** The closest hit over every instance with near < t < far, or null. */
  raycast(origin: Vec3Like, direction: Vec3Like, near?: number, far?: number): InstanceHit | null;
  occluded(origin: Vec3Like, direction: Vec3Like, near?: number, far?: number): boolean;
  /** 5 floats a ray: t, face index (u32 bits), u, v, instance id (u32 bits). */
  raycastMany(rays: Float32Array, hits?: Float32Array): Float32Array;
  /** Frees the top level (not the meshes). */
  dispose(): void;
}

/** Whether this engine runs WebAssembly SIMD. */
export declare function simdSupported(): boolean;
/** 'simd128' or 'scalar' once loaded, else null. */
export declare function moduleVariant(): string | null;

type Source = WebAssembly.Module | BufferSource | Response | PromiseLike<Response> | string | URL;
/**
 * kdray/core only: loads the module from a URL (fetched; in Node a `file:` URL, as
 * `import.meta.resolve` gives, or a path is read from the disk), bytes, a Response or a compiled
 * module ({ simd128, scalar }: the one this engine runs).
 */
export declare function init(source: Source | { simd128: Source; scalar: Source }): Promise<void>;
